#!/usr/bin/env bash
# docs/distributed.md: Homer P3 and Bunny P2 on the distributed-mesh route (rank 0 reads the mesh,
# DMPlex distributes it with PT-Scotch; no refinement, so the mesh is the serial one) on 1-4 ranks
# against pmgkit's serial MGPCG, to 1e-10: iterations, the compliance bᵀu (independent of the
# numbering) and the largest ghost/owned ratio. 1 thread per rank, oversubscribed beyond 2 ranks.
#   docs/results/distributed_mesh_models.sh > docs/results/distributed_mesh_models_$(date +%F).txt 2>&1
set -u
cd "$(dirname "$0")/../.."
pmg=build/tools/pmg
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
date; uname -n; nproc
for sys in "homer|--mesh models/homer.ele -p 3 --fix z --fix-fraction 0.05 --load gravity" \
           "bunny|--mesh models/bunny_17k.ele -p 2 --fix y --fix-fraction 0.05 --load gravity"; do
  name=${sys%%|*} args=${sys#*|}
  echo "=== $name: pmg compare $args --tol 1e-10"
  OMP_NUM_THREADS=1 $pmg compare $args --tol 1e-10 --solvers mgpcg --no-reference --json "$work/serial.json" > /dev/null
  for np in 1 2 3 4; do
    mpirun --allow-run-as-root --oversubscribe --bind-to none -x OMP_NUM_THREADS=1 -np $np \
      $pmg compare $args --tol 1e-10 --distributed-mesh --json "$work/np$np.json" > /dev/null
  done
  /usr/bin/python3 - "$work" <<'PY'
import json, sys
w = sys.argv[1]
s = json.load(open(f"{w}/serial.json"))
row = next(r for r in s["solvers"] if r["name"] == "mgpcg")
print(f"serial mgpcg: {row['iterations']} iterations, b.u = {row['b_dot_x']:.12e} J")
for np_ in (1, 2, 3, 4):
    d = json.load(open(f"{w}/np{np_}.json"))
    ratio = max(g["ghosts"] / g["owned"] for g in d["finest level ghost/owned nodes per rank"])
    diff = abs(d["compliance (J)"] - row["b_dot_x"]) / abs(row["b_dot_x"])
    print(f"distributed mesh np {np_}: {d['unknowns']} unknowns, {d['iterations']} iterations, "
          f"true residual {d['true_relative_residual']:.2e}, b.u = {d['compliance (J)']:.12e} J "
          f"(relative difference {diff:.1e}), largest ghost/owned {100 * ratio:.1f}%")
PY
done
date
