#!/usr/bin/env bash
# Time steps on a mesh no rank holds whole (pmg simulate --distributed-mesh) against pmgkit's serial
# time step (MGPCG) and the replicated petsc-mgpcg route: the quadratic cantilever bar (16x4x4
# boxes of 24 tetrahedra over 4 x 1 x 1 m, refined once: 96,000 tetrahedra, 409,440 unknowns; the
# serial and replicated runs refine the whole mesh, the distributed one on the ranks), corotational,
# released from its static deflection under a 4 kN end force, 10 steps of 0.01 s, each solved to
# 1e-3 with a warm start, no output files. Whole-job wall time and peak resident memory of every
# process by /usr/bin/time (%e s, %M kB); the report's set-up, deflection and step figures. Two
# alternating batches; np 4 on this 2-core VM is oversubscribed: its memory counts, its time
# measures overhead.
#   docs/results/distributed_simulate.sh > docs/results/distributed_simulate_$(date +%F).txt 2>&1
set -u
cd "$(dirname "$0")/../.."
pmg=build/tools/pmg
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
/usr/bin/python3 - "$work" <<'PY'
import json, sys
base = {"name": "cantilever bar 20x5x5 refined once, degree 2, released from its deflection",
        "mesh": {"box": [20, 5, 5], "size": [4, 1, 1], "refine": 1}, "degree": 2,
        "material": {"model": "corotational", "young": 5e6, "poisson": 0.3, "density": 1000},
        "clamp": {"axis": "x", "fraction": 0.0},
        "initial": {"state": "deflected", "force": [0, 0, -4000]},
        "time": {"dt": 0.01, "duration": 0.1}, "output": {"energy": True}}
for name, solver in (("serial", {"method": "mgpcg", "tol": 1e-3}),
                     ("replicated", {"method": "petsc-mgpcg", "tol": 1e-3}),
                     ("mesh", {"method": "petsc-mgpcg", "tol": 1e-3})):
    json.dump(dict(base, solver=solver), open("%s/%s.json" % (sys.argv[1], name), "w"))
PY
mpi=(mpirun --allow-run-as-root --oversubscribe --bind-to none)
run() {  # run TITLE COMMAND...
  echo "=== $1"
  shift
  "$@" 2>&1 | grep -E "^(mesh|set-up|steps|probe|energy|note: +initial|rank|peak|pmg: error)" 
}
date; uname -n; lscpu | grep "Model name"; nproc
for batch in 1 2; do
  echo "##### batch $batch"
  run "serial mgpcg, 1 thread" env OMP_NUM_THREADS=1 /usr/bin/time -f "peak %M kB, %e s" $pmg simulate "$work/serial.json" -q
  run "distributed mesh, np 1 x 1 thread" "${mpi[@]}" -np 1 -x OMP_NUM_THREADS=1 /usr/bin/time -f "rank peak %M kB, %e s" $pmg simulate "$work/mesh.json" -q --distributed-mesh
  run "distributed mesh, np 2 x 1 thread" "${mpi[@]}" -np 2 -x OMP_NUM_THREADS=1 /usr/bin/time -f "rank peak %M kB, %e s" $pmg simulate "$work/mesh.json" -q --distributed-mesh
  run "replicated petsc-mgpcg, np 2 x 1 thread" "${mpi[@]}" -np 2 -x OMP_NUM_THREADS=1 /usr/bin/time -f "rank peak %M kB, %e s" $pmg simulate "$work/replicated.json" -q
  run "distributed mesh, np 4 x 1 thread (oversubscribed)" "${mpi[@]}" -np 4 -x OMP_NUM_THREADS=1 /usr/bin/time -f "rank peak %M kB, %e s" $pmg simulate "$work/mesh.json" -q --distributed-mesh
done
date
