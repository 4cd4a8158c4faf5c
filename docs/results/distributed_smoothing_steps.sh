#!/usr/bin/env bash
# petsc-mgpcg's Chebyshev steps per smoothing (the key smoothing_steps), 1, 2 and 3, on np 1 x 2
# threads of the distributed-mesh route: the once-refined 14^3-box quadratic cube (2,178,120
# unknowns, to 1e-6), a 16^3-box cubic cube (to 1e-6), and a slender quadratic bar 12 x 1 x 1
# clamped at one end at nu = 0.3 and 0.49 (to 1e-8). Two rounds, the steps alternating within each.
#   docs/results/distributed_smoothing_steps.sh > docs/results/distributed_smoothing_steps_$(date +%F).txt 2>&1
set -u
cd "$(dirname "$0")/../.."
pmg=build/tools/pmg
mpi=(mpirun --allow-run-as-root --bind-to none -np 1 -x OMP_NUM_THREADS=2)
declare -A case=(
  [p2-cube]="compare --box 14 14 14 --refine 1 --size 1 1 1 -p 2 --fix z --load gravity --tol 1e-6"
  [p3-cube]="compare --box 16 16 16 --size 1 1 1 -p 3 --fix z --load gravity --tol 1e-6"
  [bar-nu0.3]="compare --box 48 4 4 --size 12 1 1 -p 2 --fix x --load gravity --tol 1e-8 --poisson 0.3"
  [bar-nu0.49]="compare --box 48 4 4 --size 12 1 1 -p 2 --fix x --load gravity --tol 1e-8 --poisson 0.49"
)
date; uname -n; lscpu | grep "Model name"; nproc
echo "case steps: iterations, solver set-up [s], solve [s], t(1e-6 or 1e-8) [s] (or the error)"
for round in 1 2; do
  for name in p2-cube p3-cube bar-nu0.3 bar-nu0.49; do
    for steps in 1 2 3; do
      out=$("${mpi[@]}" $pmg ${case[$name]} --distributed-mesh --set smoothing_steps=$steps 2>&1)
      its=$(echo "$out" | grep -oE 'in [0-9]+ iterations' | grep -oE '[0-9]+')
      setup=$(echo "$out" | grep -oE 'set-up: [0-9.]+ s' | head -1 | grep -oE '[0-9.]+')
      solve=$(echo "$out" | grep -oE 'solve: [0-9.]+ s' | head -1 | grep -oE '[0-9.]+')
      t=$(echo "$out" | grep -oE 'set-up \+ solve [0-9.]+ s' | grep -oE '[0-9.]+')
      err=$(echo "$out" | grep -m1 -oE 'error: .*' | cut -c1-110)
      echo "round $round $name steps $steps: ${its:--} iterations, set-up ${setup:--}, solve ${solve:--}, t ${t:--} ${err}"
    done
  done
done
date
