#!/usr/bin/env bash
# The mixed displacement-pressure formulation (pmg compare --formulation mixed: Taylor-Hood BB
# elements, mixed-gmres, mixed-minres and MUMPS's LDLᵀ on the assembled saddle point) against the
# displacement-only elements (mgpcg) on the quadratic bar of the stress matrix (4 x 1 x 1 m, 8 x 2 x 2
# boxes, clamped at x = 0, gravity) and the cubic Homer (clamped at the feet, gravity), static, at
# ν = 0.3, 0.49, 0.499 and 0.4999; iterations to 1e-8 (the robustness target) and times to 1e-6;
# then one implicit-Euler step's system on Homer.
# Usage: docs/results/mixed.sh > docs/results/mixed_$(date +%F).txt   (after scripts/build.sh and
# scripts/get_models.sh with the Homer mesh made as the README says)
set -euo pipefail
pmg=${PMG:-build/tools/pmg}
bar=(--box 8 2 2 --size 4 1 1 -p 2 --fix x --load gravity --threads 2)
homer=(--mesh models/homer.ele -p 3 --fix z --fix-fraction 0.05 --load gravity --threads 2)
echo "# $(date -u +%F) $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2), $(nproc) cores"
for tol in 1e-8 1e-6; do
  for case in bar homer; do
    [ "$case" = bar ] && args=("${bar[@]}") || args=("${homer[@]}")
    for nu in 0.3 0.49 0.499 0.4999; do
      echo "## $case, nu = $nu, tol = $tol: displacement-only mgpcg"
      "$pmg" compare "${args[@]}" --poisson "$nu" --tol "$tol" --solvers mgpcg --no-reference | grep -E "^(size:|mgpcg )"
      sleep 2
      echo "## $case, nu = $nu, tol = $tol: mixed"
      "$pmg" compare "${args[@]}" --poisson "$nu" --tol "$tol" --formulation mixed | grep -vE "^(mixed-minres: MINRES|mixed-gmres: GMRES|mumps: PETSc)"
      sleep 2
    done
  done
done
# One implicit-Euler step's system (M + dt^2 K from rest, dt = 0.01 s) on Homer P3, to 1e-8.
for nu in 0.3 0.4999; do
  echo "## homer, nu = $nu, tol = 1e-8, one step dt = 0.01: displacement-only mgpcg"
  "$pmg" compare "${homer[@]}" --poisson "$nu" --tol 1e-8 --dt 0.01 --solvers mgpcg --no-reference | grep -E "^(size:|mgpcg )"
  sleep 2
  echo "## homer, nu = $nu, tol = 1e-8, one step dt = 0.01: mixed"
  "$pmg" compare "${homer[@]}" --poisson "$nu" --tol 1e-8 --dt 0.01 --formulation mixed | grep -vE "^(mixed-minres: MINRES|mixed-gmres: GMRES|mumps: PETSc)"
  sleep 2
done
