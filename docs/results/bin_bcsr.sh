#!/bin/bash
# docs/library.md and docs/performance.md: BIN-BCSR's bytes against BCSR's and the CPU SpMV of every
# format, on the spring lattice (n = 16, 64) and on FEM systems written by `pmg compare
# --export-petsc`: the box bar at degrees 1, 2, 3 (16/p boxes a side, as bench_gpu's cube) and the
# cubic Homer of the README (models/homer.ele). bench_spmv prints the layout table first (lanes,
# window, padding, bytes / BCSR's, and the unsorted one-lane layout's), then the timings.
# Run from the repository root after scripts/build.sh (and, for Homer, the README's model command).
cd "$(dirname "$0")/../.."
export OMP_NUM_THREADS=2 PMG_THREADS=fixed
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
args=()
for p in 1 2 3; do
  n=$((16 / p))
  build/tools/pmg compare --box $n $n $n --size 1 1 1 -p $p --fix z --load gravity \
    --solvers block-jacobi-pcg --max-iter 1 --export-petsc "$dir/box$p" > /dev/null
  args+=("--pmg_matrix=box_p$p=$dir/box$p/A.petsc")
done
build/tools/pmg compare --mesh models/homer.ele -p 3 --fix z --fix-fraction 0.05 --load gravity \
  --solvers block-jacobi-pcg --max-iter 1 --export-petsc "$dir/homer" > /dev/null
args+=("--pmg_matrix=homer_p3=$dir/homer/A.petsc")
date -u +"%Y-%m-%d %H:%M UTC"
build/bench/sparse/bench_spmv --pmg_sizes=16,64 "${args[@]}" "$@"
