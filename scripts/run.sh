#!/usr/bin/env bash
# The main job: installs what is missing, builds, and runs `pmg simulate` on the built-in default
# scene (a cubic cantilever released from a deflected state). Arguments are passed on to it, e.g.
# `scripts/run.sh my_scene.json` or `scripts/run.sh -o out` to write .vtu frames.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh > /dev/null
exec build/tools/pmg simulate "$@"
