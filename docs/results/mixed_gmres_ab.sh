#!/usr/bin/env bash
# Before/after of a change to mixed-gmres: Homer P3 at ν = 0.499 to 1e-6 with two builds of pmg in
# alternating rounds (3 s pauses), and the displacement-only mgpcg at ν = 0.3 each round (the
# speed target's reference).
# Usage: docs/results/mixed_gmres_ab.sh OLD_PMG NEW_PMG [ROUNDS] > docs/results/mixed_gmres_ab_$(date +%F).txt
set -euo pipefail
old=$1 new=$2 rounds=${3:-4}
homer=(--mesh models/homer.ele -p 3 --fix z --fix-fraction 0.05 --load gravity --threads 2 --tol 1e-6)
for r in $(seq "$rounds"); do
  for b in old new; do
    p=$old
    [ "$b" = new ] && p=$new
    echo "r$r $b $("$p" compare "${homer[@]}" --poisson 0.499 --formulation mixed --solvers mixed-gmres 2>&1 | grep '^mixed-gmres  ')"
    sleep 3
  done
  echo "r$r mgpcg0.3 $("$new" compare "${homer[@]}" --poisson 0.3 --solvers mgpcg --no-reference | grep '^mgpcg ')"
  sleep 3
done
