#!/bin/bash
# docs/robustness.md: Chebyshev smoothing on vertex patches (smoother.preconditioner=patch) against
# point smoothing (smoother.method=chebyshev: matrix-free Chebyshev on the 3x3 diagonal blocks, the
# default below lambda/mu = 99 and for mgpcg), as nu -> 1/2 and on thin parts.
#   1. the stress matrix's quadratic bar (8 x 2 x 2 boxes, 4 x 1 x 1 m), 10 corotational steps of
#      0.01 s to 1e-3 per step, PMG and MGPCG;
#   2. the stress matrix's thin plate (4 x 1 x 0.01 m) and rod (4 x 0.01 x 0.01 m), quadratic, from
#      rest under gravity (their deflected start is refused by CHOLMOD's residual check: see the doc);
#   3. the cubic Homer of the README (models/homer.ele), static to 1e-6: MGPCG at nu = 0.3 and 0.499
#      (also with skip_levels=1: degree 2 as the lowest level), PMG at nu = 0.3, 0.495 and 0.499;
#   4. the thin plate at degree 3, MGPCG, with and without skip_levels=1.
# Run from the repository root after scripts/build.sh (and, for 3, the README's model command).
cd "$(dirname "$0")/../.."
export OMP_NUM_THREADS=2 PMG_THREADS=fixed
scene=$(mktemp --suffix=.json)
config=$(mktemp --suffix=.json)
trap 'rm -f "$scene" "$config"' EXIT
run() {  # run MESH-KIND NU METHOD PATCH [DEGREE [EXTRA-JSON]]
  /usr/bin/python3 - "$@" > "$scene" <<'PY'
import json, sys
kind, nu, method, patch = sys.argv[1], float(sys.argv[2]), sys.argv[3], sys.argv[4] == "patch"
degree = int(sys.argv[5]) if len(sys.argv) > 5 else 2
s = {"degree": degree, "material": {"model": "corotational", "young": 5e6, "poisson": nu, "density": 1000},
     "clamp": {"axis": "x"}, "time": {"dt": 0.01, "duration": 0.1},
     "solver": {"method": method, "tol": 1e-3}}
if kind == "bar":
    s["mesh"] = {"box": [8, 2, 2], "size": [4, 1, 1]}
    s["initial"] = {"state": "deflected", "force": [0, 0, -4000]}
else:
    s["mesh"] = {"box": [8, 2, 1], "size": [4, 1, 0.01]} if kind == "plate" else {"box": [16, 1, 1], "size": [4, 0.01, 0.01]}
    s["loads"] = {"gravity": [0, 0, -9.81]}
s["solver"]["smoother.preconditioner.method" if patch else "smoother.method"] = "patch" if patch else "chebyshev"
if len(sys.argv) > 6:
    s["solver"].update(json.loads(sys.argv[6]))
print(json.dumps(s))
PY
  echo "$1 nu=$2 $3 $4 ${5:-2} ${6:-}: $(timeout 600 build/tools/pmg simulate "$scene" 2>&1 | grep -E '^steps:|error' | cut -c1-140)"
}
date -u +"%Y-%m-%d %H:%M UTC, $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2)"
for method in pmg mgpcg; do
  for nu in 0.3 0.45 0.49 0.499; do
    for smoother in point patch; do run bar $nu $method $smoother; done
  done
done
for kind in plate rod; do
  for method in pmg mgpcg; do
    for smoother in point patch; do run $kind 0.3 $method $smoother; done
  done
done
for smoother in point patch; do
  run plate 0.3 mgpcg $smoother 3
  run plate 0.3 mgpcg $smoother 3 '{"skip_levels": 1}'
done
if [ -f models/homer.ele ]; then
  homer() {  # homer NU CONFIG-JSON
    echo "$2" > "$config"
    echo "Homer P3 static, nu=$1:"
    build/tools/pmg compare --mesh models/homer.ele -p 3 --fix z --fix-fraction 0.05 --load gravity --poisson "$1" \
      --tol 1e-6 --solver-config "$config" 2>&1 | grep -E '^size|^solver|converged|stagnated|failed|one cycle|set-up [0-9]|Schwarz'
  }
  for nu in 0.3 0.499; do
    homer $nu '{"mgpcg": {"method": "mgpcg"}, "mgpcg-patch": {"method": "mgpcg", "smoother.preconditioner.method": "patch"}, "mgpcg-skip1": {"method": "mgpcg", "skip_levels": 1}, "patch-skip1": {"method": "mgpcg", "skip_levels": 1, "smoother.preconditioner.method": "patch"}}'
  done
  for nu in 0.3 0.495 0.499; do
    homer $nu '{"pmg-point": {"method": "pmg", "smoother.method": "chebyshev"}, "pmg-patch": {"method": "pmg", "smoother.preconditioner.method": "patch"}}'
  done
fi
