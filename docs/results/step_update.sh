#!/usr/bin/env bash
# One time step's update and output, and the static Homer P3 solve, alternating two builds:
#   docs/results/step_update.sh OLD_PMG [ROUNDS]
# OLD_PMG: the pmg binary of the build to compare with (e.g. a worktree's build/tools/pmg); the new
# one is build/tools/pmg. Needs models/homer.ele (docs/performance.md#the-models). Per round and
# build: the static Homer P3 MGPCG solve to 1e-6 (iterations, t(1e-6), one cycle), the twisted
# Homer of docs/results/kernels.sh (10 steps, mgpcg to 1e-3) without frames (wall, iterations per
# step, hierarchy update per step in ms) and with -o DIR (wall, output's share).
source "$(dirname "$0")/ab_common.sh"
for i in $(seq 1 "$rounds"); do
  for who in old new; do
    pmg=$(pmg_of "$who")
    s=$($pmg $static 2>&1 | awk '/^mgpcg +converged/{t=$7; it=$3} /one cycle/{c=$4} END{print "static it", it, "t6", t, "cycle", c}')
    t=$($pmg simulate "$work/twisted.json" -q 2>&1 |
      awk '/^steps:/{w=$4; it=$7} /^hierarchy update/{h=$4} END{print "twisted wall", w, "its", it, "hier_ms", h}')
    rm -rf "$work/out"
    f=$($pmg simulate "$work/twisted.json" -q -o "$work/out" 2>&1 |
      awk '/^steps:/{w=$4} /^output /{o=$3; sh=$4} END{print "twisted+frames wall", w, "output_ms_per_step", o, sh}')
    echo "$i $who | $s | $t | $f"
  done
done
