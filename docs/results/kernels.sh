#!/bin/bash
# docs/performance.md, "Element batches in SIMD lanes" and "Threads beside other load": the
# figures of the batched matrix-free kernels and the adaptive thread budget, in one run.
#   docs/results/kernels.sh [OLD_BUILD]
# Run from the repository root after scripts/build.sh and scripts/get_models.sh + `pmg mesh` of
# models/homer (README). OLD_BUILD: a directory holding the pmg binary and the libpmg_*.so of the
# commit before, run alternately with this build (A/B) where a ratio spans builds.
set -eu
old=${1:-}
export OMP_NUM_THREADS=2
run_new() { build/tools/pmg "$@"; }
run_old() { LD_LIBRARY_PATH="$old" "$old/pmg" "$@"; }
homer="--mesh models/homer.ele -p 3 --fix z --fix-fraction 0.05 --load gravity --no-reference"

echo "== roofline: build/bench/fem/bench_operator (medians of 5)"
build/bench/fem/bench_operator 2>/dev/null | sed -n '/^Roofline/,$p'

for batch in 1 2; do
  for who in new ${old:+old}; do
    echo "== batch $batch, $who: static Homer P3 to 1e-6, mgpcg and pmg"
    run_$who compare $homer --tol 1e-6 --solvers mgpcg,pmg | grep -E "^(solver|mgpcg|pmg) |one cycle"
    echo "== batch $batch, $who: time-step system (M + dt^2 K, dt 0.01) to 1e-3, mgpcg and block-jacobi-pcg"
    run_$who compare $homer --dt 0.01 --tol 1e-3 --solvers mgpcg,block-jacobi-pcg | grep -E "^(solver|mgpcg|block-jacobi-pcg) |one cycle"
  done
done

# The twisted Homer with the default solver (matrix-free MGPCG, the scene file names the chapter's
# assembled PMG), 10 steps.
work=$(mktemp -d)
trap 'rm -rf "$work"; kill $(jobs -p) 2>/dev/null || true' EXIT
/usr/bin/python3 docs/results/twisted_homer_scene.py "$work"
for batch in 1 2; do
  for who in new ${old:+old}; do
    echo "== batch $batch, $who: twisted Homer P3, 10 steps, mgpcg to 1e-3"
    run_$who simulate "$work/twisted.json" -q | grep -E "^steps:|^(hierarchy update|solve) "
  done
done

# The default scene, 50 steps, quiet and beside one busy process (a shell loop holding a core).
for batch in 1 2; do
  for who in new ${old:+old}; do
    s=$(date +%s%N); run_$who simulate --duration 0.5 -q > /dev/null; e=$(date +%s%N)
    echo "== batch $batch, $who: default scene quiet: $(( (e - s) / 1000000 )) ms"
  done
done
sh -c 'while :; do :; done' &
busy=$!
sleep 1
for batch in 1 2; do
  for who in new ${old:+old}; do
    s=$(date +%s%N); timeout 300 bash -c "$(declare -f run_$who); old=$old; run_$who simulate --duration 0.5 -q" > /dev/null; e=$(date +%s%N)
    echo "== batch $batch, $who: default scene beside a busy process: $(( (e - s) / 1000000 )) ms"
  done
  s=$(date +%s%N); PMG_THREADS=fixed run_new simulate --duration 0.5 -q > /dev/null; e=$(date +%s%N)
  echo "== batch $batch, new with PMG_THREADS=fixed: default scene beside a busy process: $(( (e - s) / 1000000 )) ms"
done
kill $busy
