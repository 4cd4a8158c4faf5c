#!/usr/bin/env bash
# The main job: installs what is missing, builds, and runs `pmg compare` on the built-in system
# (arguments are passed on to it, e.g. `scripts/run.sh --grid 40`).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh > /dev/null
exec build/tools/pmg compare "$@"
