#!/bin/bash
# docs/distributed.md, "Time steps": the twisted Homer P3 scene (scenes/homer_twisted.json), 10
# corotational steps to 1e-6, with pmgkit's serial MGPCG (2 threads), petsc-mgpcg on 1 rank x 2
# threads and on 2 ranks x 1 thread (each rank steps its own elements); two alternating batches.
# Prints the stage table of each run. Run from the repository root after scripts/build.sh.
set -eu
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
/usr/bin/python3 - "$work" <<'PY'
import json, sys
s = json.load(open("scenes/homer_twisted.json"))
import os; s["mesh"]["file"] = os.path.abspath("models/homer.ele")
s["time"] = {"dt": 0.01, "duration": 0.1}
s["output"] = {"directory": "", "energy": True, "frame_every": 0}
s["solver"] = {"method": "mgpcg", "tol": 1e-6}
json.dump(s, open(sys.argv[1] + "/serial.json", "w"))
s["solver"] = {"method": "petsc-mgpcg", "tol": 1e-6}
json.dump(s, open(sys.argv[1] + "/ranks.json", "w"))
PY
mpi="mpirun --allow-run-as-root --oversubscribe --bind-to none"
show() { grep -E "^(mesh|solver|steps|energy):|^(rotations|finest matrix|hierarchy update|forces|solve) "; }
for batch in 1 2; do
  echo "== batch $batch: serial mgpcg, OMP_NUM_THREADS=2 build/tools/pmg simulate serial.json"
  OMP_NUM_THREADS=2 build/tools/pmg simulate "$work/serial.json" -q | show
  echo "== batch $batch: petsc-mgpcg np 1 x 2 threads"
  $mpi -x OMP_NUM_THREADS=2 -np 1 build/tools/pmg simulate "$work/ranks.json" -q | show
  echo "== batch $batch: petsc-mgpcg np 2 x 1 thread"
  $mpi -x OMP_NUM_THREADS=1 -np 2 build/tools/pmg simulate "$work/ranks.json" -q | show
done
