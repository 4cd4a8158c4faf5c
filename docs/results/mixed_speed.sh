#!/usr/bin/env bash
# Homer P3 static to 1e-6: the speed targets of the mixed formulation in alternating rounds (three
# by default), one process per run, 5 s pauses: displacement-only mgpcg at ν = 0.3, 0.499 and
# 0.4999; mixed-gmres on the mixed system at the same ν, and mixed-minres, PETSc's fieldsplit with
# GAMG (fieldsplit-gmres) and MUMPS (LDLᵀ) at ν = 0.499 and 0.4999.
# Usage: docs/results/mixed_speed.sh [ROUNDS] > docs/results/mixed_speed_$(date +%F).txt
set -euo pipefail
pmg=${PMG:-build/tools/pmg}
rounds=${1:-3}
homer=(--mesh models/homer.ele -p 3 --fix z --fix-fraction 0.05 --load gravity --threads 2 --tol 1e-6)
echo "# $(date -u +%F) $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2), $(nproc) cores; columns as pmg compare prints them"
for r in $(seq "$rounds"); do
  for nu in 0.3 0.499 0.4999; do
    echo "## round $r, nu = $nu: displacement-only mgpcg (t(1e-6) = set-up + solve to 1e-6)"
    "$pmg" compare "${homer[@]}" --poisson "$nu" --solvers mgpcg --no-reference | grep -E "^mgpcg "
    sleep 5
    solvers=(mixed-gmres)
    [ "$nu" = 0.3 ] || solvers+=(mixed-minres fieldsplit-gmres mumps)
    for s in "${solvers[@]}"; do
      echo "## round $r, nu = $nu: mixed, $s (total = set-up + solve)"
      "$pmg" compare "${homer[@]}" --poisson "$nu" --formulation mixed --solvers "$s" | grep -E "^$s "
      sleep 5
    done
  done
done
