#!/usr/bin/env bash
# The threading tests (tests/adapters/test_threads.cpp: every kind of solver on several threads,
# own and shared) under ThreadSanitizer: clang 14 in build-tsan/, only what they link. A data race
# in pmgkit's code fails the run. OpenMP is LLVM's, with its Archer tool loaded, which tells
# ThreadSanitizer about OpenMP's barriers and tasks, so the OpenMP kernels (2 threads) are checked
# too. MPI, PETSc, hypre and OpenBLAS are not instrumented (their reports are ignored, and OpenBLAS
# runs one thread); their calls are checked through the one lock that serialises them
# (pmg/mpi/session.hpp).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install_clang.sh
build=build-tsan
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++-14 \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" -DPMG_TSAN=ON -DPMG_BUILD_BENCHMARKS=OFF \
  -DPMG_BUILD_TOOLS=OFF > /dev/null
cmake --build "$build" -j "$(nproc)" --target test_threads
export OMP_TOOL_LIBRARIES=/usr/lib/llvm-14/lib/libarcher.so OMP_NUM_THREADS=2 OPENBLAS_NUM_THREADS=1
export TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1 ignore_noninstrumented_modules=1"
"$build"/tests/adapters/test_threads
