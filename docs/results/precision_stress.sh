#!/bin/bash
# docs/performance.md, "A single-precision cycle": precision=single against double on the stress
# matrix's nearly incompressible quadratic bar (pmg to 1e-3 per step, 10 steps of 0.01 s).
# Run from the repository root after scripts/build.sh.
cd "$(dirname "$0")/../.."
export OMP_NUM_THREADS=2 PMG_THREADS=fixed
scene=$(mktemp --suffix=.json)
trap 'rm -f "$scene"' EXIT
for nu in 0.3 0.45 0.49 0.499; do
  for prec in double single; do
    /usr/bin/python3 - "$nu" "$prec" > "$scene" <<'PY'
import json, sys
s = {"mesh": {"box": [8, 2, 2], "size": [4, 1, 1]}, "degree": 2,
     "material": {"model": "corotational", "young": 5e6, "poisson": float(sys.argv[1]), "density": 1000},
     "clamp": {"axis": "x"}, "initial": {"state": "deflected", "force": [0, 0, -4000]},
     "time": {"dt": 0.01, "duration": 0.1}, "solver": {"method": "pmg", "tol": 1e-3, "precision": sys.argv[2]}}
print(json.dumps(s))
PY
    echo "nu=$nu $prec: $(timeout 300 build/tools/pmg simulate "$scene" 2>&1 | grep -E '^steps:|error' | cut -c1-120)"
  done
done
