#!/usr/bin/env bash
# The whole job on a refined cube with two builds in alternating rounds: `pmg compare --box N N N
# --refine 1 -p 2 --fix z --load gravity --tol 1e-6 --threads 2 --solvers mgpcg --no-reference`
# (the default MGPCG), one process per run, back to back, the builds' order swapped every round.
# Per run: iterations, load, set-up, solve, t(1e-6) (set-up + solve), the whole job (load +
# t(1e-6)), the matrix-free degree-2 set-up stage, the lowest level's set-up and the peak memory.
# Usage: docs/results/refined_job_ab.sh OLD_PMG BOX [ROUNDS] > docs/results/refined_job_ab_$(date +%F).txt
# REFINE=0 runs the unrefined cube (no coarser meshes: BoomerAMG on the linear level).
# Medians: /usr/bin/python3 docs/results/ab_medians.py FILE
set -euo pipefail
cd "$(dirname "$0")/../.."
old=$1 box=$2 rounds=${3:-3} refine=${REFINE:-1}
source docs/results/ab_rounds.sh
args=(compare --box "$box" "$box" "$box" --size 1 1 1 --refine "$refine" -p 2 --fix z --load gravity --tol 1e-6 --threads 2
      --solvers mgpcg --no-reference)
echo "# $(date -u +%FT%TZ) $(git rev-parse --short HEAD) against $old; $(nproc) cores; pmg ${args[*]}"
run() {  # run PMG: one line of figures
  /usr/bin/time -f "peak %M" "$1" "${args[@]}" 2>&1 | awk '
    /^format:/ { for (i = 1; i <= NF; ++i) if ($i == "(load") load = $(i + 1) }
    /^mgpcg +converged/ { its = $3; setup = $4; solve = $5; t6 = $7 }
    /^mgpcg: set-up/ { if (match($0, /matrix-free degree 2 [0-9.]+/)) { split(substr($0, RSTART, RLENGTH), a, " "); mf2 = a[4] }
                       if (match($0, /lowest level \([a-z]+\) [0-9.]+/)) { n = split(substr($0, RSTART, RLENGTH), a, " "); low = a[n] } }
    /^peak/ { peak = $2 / 1024 }
    END { printf "its %s load %s setup %s solve %s t6 %s whole %.3f mf2 %s lowsetup %s peak %.0f\n",
                 its, load, setup, solve, t6, load + t6, mf2, low, peak }'
}
for r in $(seq "$rounds"); do
  for who in $(ab_order "$r"); do
    echo "$r $who | $(run "$(pmg_of "$who")")"
  done
done
