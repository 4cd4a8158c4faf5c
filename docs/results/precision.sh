#!/bin/bash
# docs/performance.md, "A single-precision cycle": MGPCG and PMG with their cycles in double and in
# float (precision=single) on the static Homer P3 to a true residual of 1e-10 (with the residual
# curves plotted) and on the time-step system M + dt^2 K to 1e-3, two alternating batches.
# Run from the repository root after scripts/build.sh and the README's models.
set -eu
export OMP_NUM_THREADS=2
homer="--mesh models/homer.ele -p 3 --fix z --fix-fraction 0.05 --load gravity --no-reference"
for batch in 1 2; do
  echo "== batch $batch: static, to 1e-10"
  plot=""; [ $batch = 1 ] && plot="--plot docs/single_precision_homer.png"
  build/tools/pmg compare $homer --tol 1e-10 --solver-config docs/results/precision.json $plot |
    grep -E "^(solver|mgpcg|pmg)|one cycle"
  echo "== batch $batch: time step (dt 0.01), to 1e-3"
  build/tools/pmg compare $homer --dt 0.01 --tol 1e-3 --solver-config docs/results/precision.json |
    grep -E "^(solver|mgpcg|pmg)|one cycle"
done
