#!/usr/bin/env bash
# Configures and builds pmgkit into BUILD_DIR (default: build) in Release mode; extra arguments go
# to CMake. Used by run.sh and test.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${BUILD_DIR:-build}
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE="${BUILD_TYPE:-Release}" "$@" > /dev/null
cmake --build "$build" -j "$(nproc)"
