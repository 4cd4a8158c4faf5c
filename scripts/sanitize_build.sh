#!/usr/bin/env bash
# The clang build with AddressSanitizer + UBSan in build-asan/: the sanitizer suite
# (scripts/test.sh --sanitize) and the libFuzzer targets (scripts/fuzz.sh) live in it, so the
# libraries are compiled once for both. Installs clang 14 and its runtimes where missing.
#   scripts/sanitize_build.sh             everything (libraries, tests, tools, fuzz targets)
#   scripts/sanitize_build.sh TARGET...   those targets only (e.g. fuzz_gmsh)
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install_clang.sh
build=build-asan
# clang 14 at -O1 -g1 (line tables: enough for the sanitizers' stack traces): under ASan + UBSan,
# GCC 12 at -O2 -g took 132 s to compile fem/src/elasticity.cpp, GCC at -O1 -g1 44 s, clang at
# -O1 -g1 30 s (a test file: 43 vs 26 s).
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++-14 \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" -DPMG_FUZZ=ON > /dev/null
if [ $# -gt 0 ]; then
  cmake --build "$build" -j "$(nproc)" --target "$@"
else
  cmake --build "$build" -j "$(nproc)"
fi
