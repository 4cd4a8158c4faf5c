#!/usr/bin/env bash
# The static Homer P3 set-up by stage and the twisted Homer's force evaluation per step,
# alternating two builds:
#   docs/results/setup_forces.sh OLD_PMG [ROUNDS]
# OLD_PMG: the pmg binary of the build to compare with (e.g. a worktree's build/tools/pmg); the new
# one is build/tools/pmg. Needs models/homer.ele (docs/performance.md#the-models). Per round and
# build: the MGPCG set-up of the static Homer P3 solve to 1e-6 (its wall time and the stages
# "smoother degree 3", "smoother degree 2", "lowest level") and the twisted Homer of
# docs/results/kernels.sh (10 steps, mgpcg to 1e-3): its "forces" stage per step in ms (element
# force and energy, b = M v + dt (f_ext + f)) and the wall time of the steps.
source "$(dirname "$0")/ab_common.sh"
for i in $(seq 1 "$rounds"); do
  for who in old new; do
    pmg=$(pmg_of "$who")
    s=$($pmg $static 2>&1 | awk '/^mgpcg +converged/{su=$4} /set-up [0-9]/{for (k=1;k<=NF;k++) {if ($k=="3" && $(k-1)=="degree" && $(k-2)=="smoother") s3=$(k+1); if ($k=="2" && $(k-1)=="degree" && $(k-2)=="smoother") s2=$(k+1); if ($k=="(cholmod)") lo=$(k+1)}} END{print "setup", su, "smoother3", s3, "smoother2", s2, "lowest", lo}')
    t=$($pmg simulate "$work/twisted.json" -q 2>&1 | awk '/^forces/{f=$3} /^steps:/{w=$4} END{print "forces_ms", f, "wall", w}')
    echo "$i $who | $s | $t"
  done
done
