#!/usr/bin/env bash
# The lowest level on the coarsest of a refined cube's coarser meshes: CHOLMOD or BoomerAMG with k
# V-cycles per application, the default MGPCG otherwise. Quadratic cube of N^3 boxes refined once,
# clamped at z = 0, gravity, to 1e-6 from zero, 2 threads; REPS rounds over the configurations in
# the order given, one process per run. Per run: iterations, set-up, solve, t(1e-6), the relative
# residual, one cycle and its lowest-level solve in ms.
# Usage: docs/results/coarse_cycles.sh N REPS CONFIG... (CONFIG: chol, or k for k V-cycles)
#   docs/results/coarse_cycles.sh 14 3 chol 2 3 >> docs/results/coarse_cycles_$(date +%F).txt
set -euo pipefail
cd "$(dirname "$0")/../.."
box=$1 reps=$2
shift 2
for r in $(seq "$reps"); do
  for c in "$@"; do
    if [ "$c" = chol ]; then set_=(lowest_level=cholmod); else set_=(lowest_level=boomeramg lowest_level.cycles="$c"); fi
    out=$(build/tools/pmg compare --box "$box" "$box" "$box" --size 1 1 1 --refine 1 -p 2 --fix z --load gravity \
      --tol 1e-6 --threads 2 --solvers mgpcg --no-reference --set "${set_[@]}" 2>&1)
    it=$(echo "$out" | awk '/^mgpcg +conv/{print $3, $4, $5, $7, $8}')
    cyc=$(echo "$out" | grep -o "one cycle [0-9.]* ms" | awk '{print $3}')
    low=$(echo "$out" | grep -o "lowest-level solve [0-9.]* ms" | awk '{print $3}')
    echo "box $box cfg $c iters/setup/solve/t/res $it cycle $cyc lowest $low"
  done
done
