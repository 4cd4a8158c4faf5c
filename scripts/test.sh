#!/usr/bin/env bash
# Installs what is missing, builds, and runs the whole test suite (unit tests, tool tests, the
# benchmark smoke runs and the installed-package consumer build).
#   scripts/test.sh             Release build in build/
#   scripts/test.sh --sanitize  AddressSanitizer + UBSan build in build-asan/
#   scripts/test.sh --validation  also the long validation runs and the stability stress matrix
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
# ctest runs two tests at a time, each with OpenMP threads: libgomp's threads spin while they wait,
# and two spinning teams on two cores starve each other (two concurrent `pmg coarse` runs took
# 112 s instead of 3 s; the suite 206 s instead of 93 s). Waiting threads sleep in the tests.
export OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-passive}"
if [ "${1:-}" = "--sanitize" ]; then
  export BUILD_DIR=build-asan BUILD_TYPE=RelWithDebInfo
  # clang 14 (installed here if missing), at -O1 -g1 (line tables: enough for the sanitizers'
  # stack traces): under ASan + UBSan, GCC 12 at -O2 -g took 132 s to compile
  # fem/src/elasticity.cpp, GCC at -O1 -g1 44 s, clang at -O1 -g1 30 s (a test file: 43 vs 26 s).
  scripts/install_clang.sh
  scripts/build.sh -DPMG_SANITIZE=ON -DCMAKE_CXX_COMPILER=clang++-14 \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG"
  export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1
  # The consumer check installs and links a plain build, and the validation runs are the same
  # code on larger meshes: under sanitizers they add time, not coverage.
  ctest --test-dir build-asan --output-on-failure -j 2 -LE "install|validation|stress|studies"
else
  scripts/build.sh
  if [ "${1:-}" = "--validation" ]; then
    ctest --test-dir build --output-on-failure -j 2 -LE stress
    ctest --test-dir build --output-on-failure -L stress
  else
    ctest --test-dir build --output-on-failure -j 2 -LE "validation|stress"
  fi
fi
