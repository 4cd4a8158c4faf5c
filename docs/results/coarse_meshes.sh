#!/usr/bin/env bash
# The coarser meshes under the linear level (coarse_meshes=on, the default for mgpcg from 40,000
# linear unknowns) against BoomerAMG on the linear level itself (coarse_meshes=off), on the same
# refined meshes: the 14^3-box cube refined once (2,178,120 unknowns) and the 23^3-box cube
# refined once (9,592,104 unknowns), quadratic, clamped at z = 0, gravity, to 1e-6 from zero,
# 2 threads. Two pairs per size, the order alternating, a 10 s pause before each run. Per run:
# the load and set-up by stage, iterations, solve, t(1e-6) and the peak memory.
#   docs/results/coarse_meshes.sh > docs/results/coarse_meshes_$(date +%F).txt 2>&1
set -u
cd "$(dirname "$0")/../.."
pmg=build/tools/pmg
date; uname -n; lscpu | grep "Model name"; nproc
run() {  # run BOX MODE
  sleep 10
  echo "== box $1 refined once, coarse_meshes=$2"
  /usr/bin/time -f "peak %M KB, wall %e s" $pmg compare --box "$1" "$1" "$1" --refine 1 --size 1 1 1 -p 2 --fix z \
    --load gravity --tol 1e-6 --threads 2 --solvers mgpcg --no-reference --set coarse_meshes="$2" 2>&1 |
    grep -E "^size|^load|^mgpcg +conv|^mgpcg: set-up|^mgpcg: one cycle|lowest level (multigrid|boomeramg)|^peak" |
    sed 's/; levels above.*//'
}
for box in 14 23; do
  for pair in 1 2; do
    if [ "$pair" = 1 ]; then run $box on; run $box off; else run $box off; run $box on; fi
  done
done
date
