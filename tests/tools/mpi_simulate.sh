#!/usr/bin/env bash
# mpi_simulate.sh PMG SCENE: 20 corotational steps of the quadratic cantilever with pmgkit's serial
# MGPCG, and the same scene with petsc-mgpcg on 2 MPI ranks (oversubscribed), which step their own
# elements: the probe and the energies of every step agree to 1e-8, rank 0 alone writes steps.csv,
# and each distributed frame is a .pvtu of one .vtu piece per rank that VTK reads, its displacement
# at every control point the serial frame's to 1e-8.
set -u
pmg=$1 scene=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "mpi_simulate.sh: $*"; exit 1; }
/usr/bin/python3 - "$scene" "$work" <<'PY' || fail "cannot write the scenes"
import json, sys
s = json.load(open(sys.argv[1]))
s["degree"] = 2
s["time"] = {"dt": 0.01, "duration": 0.2}
s["output"] = {"directory": "", "energy": True, "frame_every": 10}
s["solver"] = {"method": "mgpcg", "tol": 1e-11, "lowest_level": "cholmod"}
json.dump(s, open(sys.argv[2] + "/serial.json", "w"))
s["solver"] = {"method": "petsc-mgpcg", "tol": 1e-11}
json.dump(s, open(sys.argv[2] + "/distributed.json", "w"))
PY
OMP_NUM_THREADS=1 "$pmg" simulate "$work/serial.json" -o "$work/serial" -q || fail "the serial run failed"
mpi=(mpirun --allow-run-as-root --oversubscribe --bind-to none -x OMP_NUM_THREADS=1)
[ -n "${ASAN_OPTIONS:-}" ] && mpi+=(-x ASAN_OPTIONS)  # the sanitizer build: Open MPI's own leaks off
"${mpi[@]}" -np 2 \
  "$pmg" simulate "$work/distributed.json" -o "$work/distributed" -q > "$work/out.txt" 2>&1 || { cat "$work/out.txt"; fail "the 2-rank run failed"; }
cat "$work/out.txt"
[ "$(grep -c '^output:' "$work/out.txt")" = 1 ] || fail "expected one report (rank 0)"
/usr/bin/python3 - "$work/serial/steps.csv" "$work/distributed/steps.csv" <<'PY' || fail "the runs differ"
import csv, sys
a, b = (list(csv.DictReader(open(p))) for p in sys.argv[1:3])
assert len(a) == len(b) == 21, (len(a), len(b))
worst = 0.0
for ra, rb in zip(a, b):
    for k in ("probe_ux", "probe_uz", "kinetic", "elastic", "total_energy"):
        x, y = float(ra[k]), float(rb[k])
        scale = max(abs(float(ra["probe_uz"])), 1e-30) if k.startswith("probe") else max(float(ra["total_energy"]), 1e-30)
        worst = max(worst, abs(x - y) / scale)
print("largest relative difference over 20 steps:", worst)
assert worst < 1e-8
PY
ls "$work/distributed"
/usr/bin/python3 - "$work/serial" "$work/distributed" <<'PY' || fail "the frames differ"
import sys
import numpy as np
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkIOXML import vtkXMLPUnstructuredGridReader, vtkXMLUnstructuredGridReader
serial, dist = sys.argv[1:3]
pvd = open(dist + "/simulation.pvd").read()
for step in (0, 10, 20):
    name = "frame_%06d" % step
    assert name + ".pvtu" in pvd, (name, pvd)
    pieces = open("%s/%s.pvtu" % (dist, name)).read()
    assert pieces.count("<Piece ") == 2, pieces
    def read(reader, path):
        reader.SetFileName(path)
        reader.Update()
        g = reader.GetOutput()
        return vtk_to_numpy(g.GetPoints().GetData()), vtk_to_numpy(g.GetPointData().GetArray("displacement")), g.GetNumberOfCells()
    xs, us, cs = read(vtkXMLUnstructuredGridReader(), "%s/%s.vtu" % (serial, name))
    xd, ud, cd = read(vtkXMLPUnstructuredGridReader(), "%s/%s.pvtu" % (dist, name))
    assert cs == cd, (cs, cd)  # every element in exactly one piece
    assert len(xd) > len(xs)   # the nodes on the cut appear in both pieces
    at = {tuple(np.round(x, 9)): u for x, u in zip(xs, us)}
    scale = max(np.abs(us).max(), 1e-30)
    worst = max(np.abs(at[tuple(np.round(x, 9))] - u).max() for x, u in zip(xd, ud)) / scale
    print("%s: %d cells, %d points in the pieces (%d serial), largest relative difference %.2e" % (name, cd, len(xd), len(xs), worst))
    assert worst < 1e-8
PY
echo "mpi_simulate.sh: ok"
