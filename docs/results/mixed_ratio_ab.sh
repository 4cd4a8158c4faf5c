#!/usr/bin/env bash
# Issue 50's speed ratio with two builds in alternating rounds: per round and build, mixed GMRES on
# Homer P3 at ν = 0.499 (set-up + solve to 1e-6) and the displacement-only MGPCG at ν = 0.3
# (t(1e-6)), one process each, back to back: the builds' order swapped every round and the two
# commands' order every other round (the first process after a pause ran slower on this VM).
# Usage: docs/results/mixed_ratio_ab.sh OLD_PMG [ROUNDS] > docs/results/mixed_ratio_ab_$(date +%F).txt
# Medians: /usr/bin/python3 docs/results/ab_medians.py FILE
set -euo pipefail
cd "$(dirname "$0")/../.."
old=$1 rounds=${2:-8}
source docs/results/ab_rounds.sh
homer=(--mesh models/homer.ele -p 3 --fix z --fix-fraction 0.05 --load gravity --threads 2 --no-reference --tol 1e-6)
echo "# $(date -u +%FT%TZ) $(git rev-parse --short HEAD) against $old; $(nproc) cores"
echo "# mixed: ${homer[*]} --poisson 0.499 --formulation mixed --solvers mixed-gmres (iterations, set-up + solve s)"
echo "# mgpcg: ${homer[*]} --solvers mgpcg (iterations, t(1e-6) s); ratio = mixed / mgpcg"
# The round's build is $p: iterations and seconds of each command.
mixed() { "$p" compare "${homer[@]}" --poisson 0.499 --formulation mixed --solvers mixed-gmres 2>&1 | awk '/^mixed-gmres  /{print $2, $5}'; }
mgpcg() { "$p" compare "${homer[@]}" --solvers mgpcg 2>&1 | awk '/^mgpcg /{print $3, $7}'; }
for r in $(seq "$rounds"); do
  for who in $(ab_order "$r"); do
    p=$(pmg_of "$who")
    if [ $(((r / 2) % 2)) -eq 0 ]; then m=$(mixed); g=$(mgpcg); else g=$(mgpcg); m=$(mixed); fi
    read -r mi mt <<< "$m"
    read -r gi gt <<< "$g"
    echo "$r $who | mixed its $mi total $mt | mgpcg its $gi t6 $gt | ratio $(awk -v a="$mt" -v b="$gt" 'BEGIN{printf "%.3f", a/b}')"
  done
done
