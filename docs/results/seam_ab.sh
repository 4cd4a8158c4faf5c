#!/usr/bin/env bash
# The seam refactoring against the commit before it: instruction counts (callgrind, 1 thread:
# repeatable whatever else the machine does) and wall-clock medians of alternating runs (2
# threads) of the default scene and of static Homer P3 with mgpcg to 1e-6.
#   docs/results/seam_ab.sh BASE_PMG NEW_PMG [ROUNDS]
# BASE_PMG, NEW_PMG: the pmg binaries of the two builds (e.g. a worktree of the earlier commit).
# Needs models/homer.ele (scripts/get_models.sh; pmg mesh models/homer.off --tets 5150 -o models/homer).
set -euo pipefail
base=$1 new=$2 rounds=${3:-7}
homer=(compare --mesh models/homer.ele -p 3 --fix z --fix-fraction 0.05 --load gravity --tol 1e-6 --solvers mgpcg)
out=$(mktemp -d)
echo "== instruction counts (valgrind --tool=callgrind, OMP_NUM_THREADS=1) =="
for v in base new; do
  pmg=$base; [ $v = new ] && pmg=$new
  for run in "simulate --duration 0.2 -q" "${homer[*]} --no-reference"; do
    # GLIBC_TUNABLES set: pmg does not re-execute itself for huge pages (valgrind follows no exec)
    OMP_NUM_THREADS=1 PMG_THREADS=fixed GLIBC_TUNABLES=glibc.malloc.hugetlb=1 \
      valgrind --tool=callgrind --callgrind-out-file="$out/cg" "$pmg" $run > /dev/null 2>&1
    printf "%-4s %-10s total %s\n" $v "${run%% *}" "$(grep -m1 '^summary:' "$out/cg" | cut -d' ' -f2)"
    callgrind_annotate --inclusive=yes "$out/cg" 2>/dev/null |
      grep -E 'pmg::Cg::solve_impl|ImplicitEuler::step\(\)|MultigridCycle::solve_impl' | sed 's/ \[.*//; s/^/     /'
  done
done
echo "== wall clock: alternating runs, 2 threads, medians of $rounds =="
for r in $(seq "$rounds"); do
  for v in base new; do
    pmg=$base; [ $v = new ] && pmg=$new
    (cd "$out" && PMG_THREADS=fixed "$pmg" simulate --json "sim_${v}_$r.json" > /dev/null)
    PMG_THREADS=fixed "$pmg" "${homer[@]}" --json "$out/homer_${v}_$r.json" > /dev/null
  done
done
/usr/bin/python3 - "$out" "$rounds" <<'PY'
import json, statistics, sys
out, rounds = sys.argv[1], int(sys.argv[2])
for v in ("base", "new"):
    sim = [json.load(open(f"{out}/sim_{v}_{r}.json")) for r in range(1, rounds + 1)]
    hom = [json.load(open(f"{out}/homer_{v}_{r}.json"))["solvers"][0] for r in range(1, rounds + 1)]
    print(f"{v}: default scene {statistics.median(s['steps']['wall_s'] for s in sim):.3f} s "
          f"(min {min(s['steps']['wall_s'] for s in sim):.3f}, max {max(s['steps']['wall_s'] for s in sim):.3f}), "
          f"{sim[0]['steps']['iterations_per_step']} cycles per step, final energy {sim[0]['energy']['final_J']:.10g} J; "
          f"Homer P3 mgpcg t(1e-6) {statistics.median(h['time_to_1e-6_s'] for h in hom):.3f} s "
          f"(min {min(h['time_to_1e-6_s'] for h in hom):.3f}, max {max(h['time_to_1e-6_s'] for h in hom):.3f}), "
          f"{hom[0]['iterations']} iterations, residual {hom[0]['rel_residual']:.4g}, error {hom[0]['rel_error']:.4g}")
PY
rm -rf "$out"
