#!/bin/bash
# docs/gpu.md's device check in one run, for a machine with a CUDA GPU (the device tool's H200):
# build the GPU targets once, run the GPU tests, bench_gpu (SpMV in every format with BIN-BCSR's
# layout, the matrix-free operator, MCG, the V-cycle) and `pmg compare` with every GPU solver
# beside the CPU ones on the quadratic cube (515k unknowns) and the cubic Homer. Logs go to $OUT
# (default gpu_logs/); the summaries are printed at the end. Run from the repository root; models/
# (ignored by git) must be carried to the device for Homer.
set -u
cd "$(dirname "$0")/../.."
out=${OUT:-gpu_logs}
mkdir -p "$out"
{ date -u; nvidia-smi; /usr/local/cuda/bin/nvcc --version; nproc; } > "$out/info.txt" 2>&1
arch=${PMG_CUDA_ARCH:-90}
if ! { cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DCMAKE_CUDA_ARCHITECTURES="$arch" &&
       cmake --build build -j "$(nproc)" --target pmg test_gpu test_gpu_factory test_gpu_host bench_gpu; } \
     > "$out/build.txt" 2>&1; then
  echo "build failed"; tail -40 "$out/build.txt"; exit 1
fi
export OMP_NUM_THREADS=$(nproc)
(cd build && ./tests/gpu/test_gpu_host && ./tests/gpu/test_gpu && ./tests/gpu/test_gpu_factory) > "$out/tests.txt" 2>&1
echo "GPU tests: exit $? ($(grep -c 'All tests passed' "$out/tests.txt") of 3 programs passed)"
timeout 240 build/bench/gpu/bench_gpu --benchmark_repetitions=3 --benchmark_min_time=0.1 > "$out/bench.txt" 2>&1
solvers=gpu-mgpcg,gpu-pmg,gpu-mcg,gpu-pcg,mgpcg,pmg,block-jacobi-pcg,cholmod
timeout 240 build/tools/pmg compare --box 17 17 17 --size 1 1 1 -p 2 --fix z --load gravity -t 1e-6 --warm-up \
  --solvers "$solvers" > "$out/compare_cube.txt" 2>&1
if [ -f models/homer.ele ]; then
  timeout 120 build/tools/pmg compare --mesh models/homer.ele -p 3 --fix z --fix-fraction 0.05 --load gravity \
    -t 1e-6 --warm-up --solvers "$solvers" > "$out/compare_homer.txt" 2>&1
fi
grep -A40 '^Summary' "$out/bench.txt"
for f in "$out"/compare_*.txt; do echo "== $f"; sed -n '/^solver/,/^$/p' "$f"; grep -E '^gpu-.*(failed|set-up)' "$f"; done
