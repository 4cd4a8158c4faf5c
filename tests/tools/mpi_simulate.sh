#!/usr/bin/env bash
# mpi_simulate.sh PMG SCENE STATIC_SCENE: 20 corotational steps of the quadratic cantilever released from its
# static deflection with pmgkit's serial MGPCG, and the same scene across MPI ranks (oversubscribed:
# equality, not speed) which step their own elements — with petsc-mgpcg on 2 ranks from the
# replicated set-up, and with --distributed-mesh on 1, 2 and 3 ranks, none holding the whole mesh
# (the deflected start solved across the ranks): the probe and the energies of every step agree
# to 1e-8, rank 0 alone writes steps.csv, and each distributed frame is a .pvtu of one .vtu piece
# per rank that VTK reads, its displacement at every control point the serial frame's to 1e-8. A
# start given by a formula (twisted, under gravity), a half bar with a symmetry plane, a stiffer
# inclusion and a free spinning bar on the distributed mesh agree the same way, a static corotational scene gives the
# serial probe to 1e-7 and a static.pvtu; bad input ends every rank with one clear error.
set -u
pmg=$1 scene=$2 static=$3
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
compare_runs() {  # compare_runs SERIAL_DIR DIST_DIR RANKS: steps.csv and three frames agree
  /usr/bin/python3 - "$1/steps.csv" "$2/steps.csv" <<'PY' || fail "$2: the runs differ"
import csv, sys
a, b = (list(csv.DictReader(open(p))) for p in sys.argv[1:3])
assert len(a) == len(b) == 21, (len(a), len(b))
worst = 0.0
probe_scale = max(max(abs(float(r[k])) for k in ("probe_ux", "probe_uy", "probe_uz")) for r in a)
for ra, rb in zip(a, b):
    for k in ("probe_ux", "probe_uy", "probe_uz", "kinetic", "elastic", "total_energy"):
        x, y = float(ra[k]), float(rb[k])
        scale = probe_scale if k.startswith("probe") else max(float(ra["kinetic"]) + float(ra["elastic"]), 1e-30)
        worst = max(worst, abs(x - y) / scale)
print("largest relative difference of the probe and energies over 20 steps:", worst)
assert worst < 1e-8
PY
  /usr/bin/python3 - "$1" "$2" "$3" <<'PY' || fail "$2: the frames differ"
import sys
import numpy as np
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkIOXML import vtkXMLPUnstructuredGridReader, vtkXMLUnstructuredGridReader
serial, dist, ranks = sys.argv[1], sys.argv[2], int(sys.argv[3])
pvd = open(dist + "/simulation.pvd").read()
for step in (0, 10, 20):
    name = "frame_%06d" % step
    assert name + ".pvtu" in pvd, (name, pvd)
    pieces = open("%s/%s.pvtu" % (dist, name)).read()
    assert pieces.count("<Piece ") == ranks, pieces
    def read(reader, path):
        reader.SetFileName(path)
        reader.Update()
        g = reader.GetOutput()
        return vtk_to_numpy(g.GetPoints().GetData()), vtk_to_numpy(g.GetPointData().GetArray("displacement")), g.GetNumberOfCells()
    xs, us, cs = read(vtkXMLUnstructuredGridReader(), "%s/%s.vtu" % (serial, name))
    xd, ud, cd = read(vtkXMLPUnstructuredGridReader(), "%s/%s.pvtu" % (dist, name))
    assert cs == cd, (cs, cd)  # every element in exactly one piece
    assert len(xd) > len(xs) if ranks > 1 else len(xd) == len(xs)  # the nodes on a cut appear in both pieces
    at = {tuple(np.round(x, 9)): u for x, u in zip(xs, us)}
    scale = max(np.abs(us).max(), 1e-30)
    worst = max(np.abs(at[tuple(np.round(x, 9))] - u).max() for x, u in zip(xd, ud)) / scale
    print("%s: %d cells, %d points in the pieces (%d serial), largest relative difference %.2e" % (name, cd, len(xd), len(xs), worst))
    assert worst < 1e-8
PY
}
run_ranks() {  # run_ranks NP OUT_DIR ARGS...: one report (rank 0's)
  local np=$1 out=$2
  shift 2
  "${mpi[@]}" -np "$np" "$pmg" simulate "$@" -o "$out" -q > "$out.txt" 2>&1 || { cat "$out.txt"; fail "$out: the $np-rank run failed"; }
  cat "$out.txt"
  [ "$(grep -c '^output:' "$out.txt")" = 1 ] || fail "$out: expected one report (rank 0)"
}

run_ranks 2 "$work/distributed" "$work/distributed.json"
compare_runs "$work/serial" "$work/distributed" 2
for np in 1 2 3; do
  run_ranks $np "$work/mesh$np" "$work/serial.json" --distributed-mesh
  grep -q "solved across the ranks" "$work/mesh$np.txt" || fail "np $np: the deflected start was not solved across the ranks"
  compare_runs "$work/serial" "$work/mesh$np" $np
done

edited_scene() {  # edited_scene NAME EDIT: serial.json changed by the Python statements EDIT (on s) as NAME.json
  /usr/bin/python3 - "$work" "$2" "$1" <<'PY' || fail "cannot write the $1 scene"
import json, sys
s = json.load(open(sys.argv[1] + "/serial.json"))
exec(sys.argv[2])
json.dump(s, open("%s/%s.json" % (sys.argv[1], sys.argv[3]), "w"))
PY
}
against_serial() {  # against_serial NAME NP EDIT: the edited scene serially and on NP ranks, compared
  local name=$1 np=$2
  edited_scene "$name" "$3"
  OMP_NUM_THREADS=1 "$pmg" simulate "$work/$name.json" -o "$work/${name}_serial" -q > /dev/null ||
    fail "the serial $name run failed"
  run_ranks "$np" "$work/$name$np" "$work/$name.json" --distributed-mesh
  compare_runs "$work/${name}_serial" "$work/$name$np" "$np"
}
# A start given by a formula on each rank's own nodes, under gravity, with a probe point.
against_serial twisted 3 's["initial"] = {"state": "twisted", "degrees": 60}
s["loads"] = {"gravity": [0, 0, -9.81]}
s["output"]["probe"] = [3.9, 0.8, 0.3]'
# A symmetry plane (the bar's half, u_y held on y = max).
against_serial half 2 's["mesh"]["box"], s["mesh"]["size"] = [8, 1, 2], [4, 0.5, 1]
s["symmetry"] = [{"axis": "y", "at": "max"}]'
# A stiffer inclusion (E x 10 in the middle third of the bar).
against_serial inclusion 2 's["material"]["inclusion"] = {"min": [1.3, -1, -1], "max": [2.7, 2, 2], "young": 5e7}'
# A free body (no clamp) spinning: its mass keeps every step's system definite on the ranks too.
against_serial spinning 2 's["mesh"]["box"], s["mesh"]["size"] = [4, 1, 1], [2, 0.5, 0.5]
s["clamp"] = "none"
s["initial"] = {"state": "spinning", "omega": [0, 0, 3]}
s["material"]["young"] = 5e5'

# A static corotational scene (the cubic bar sagging under gravity): the serial fixed point's probe
# to 1e-7 (both stop at a relative change of 1e-6, the serial one's solves by CHOLMOD), and
# static.pvtu with one piece per rank.
OMP_NUM_THREADS=1 "$pmg" simulate "$static" --json "$work/static_serial.json" > /dev/null || fail "the serial static run failed"
"${mpi[@]}" -np 3 "$pmg" simulate "$static" --distributed-mesh -o "$work/static3" --json "$work/static3.json" \
  > "$work/static3.txt" 2>&1 || { cat "$work/static3.txt"; fail "the static scene on 3 ranks failed"; }
cat "$work/static3.txt"
[ -s "$work/static3/static.pvtu" ] && [ "$(grep -c "<Piece " "$work/static3/static.pvtu")" = 3 ] || fail "no static.pvtu of 3 pieces"
/usr/bin/python3 - "$work/static_serial.json" "$work/static3.json" <<'PY' || fail "the static scene differs"
import json, sys
a, b = (json.load(open(p)) for p in sys.argv[1:3])
pa, pb = a["probe"]["displacement_m"], b["probe"]["displacement_m"]
scale = max(abs(x) for x in pa)
worst = max(abs(x - y) for x, y in zip(pa, pb)) / scale
print("static probe", pa, "across 3 ranks", pb, "relative difference", worst,
      "fixed-point iterations", a["static"]["iterations"], b["static"]["iterations"])
assert worst < 1e-7 and a["static"]["iterations"] == b["static"]["iterations"]
PY

# What the distributed mesh does not take: one error, exit 2, on every rank, never a hang.
expect_error() {  # expect_error PATTERN SCENE_EDIT: the edited scene on 2 ranks
  edited_scene bad "$2"
  timeout 120 "${mpi[@]}" -np 2 "$pmg" simulate "$work/bad.json" --distributed-mesh -q > "$work/err.txt" 2>&1
  local rc=$?
  cat "$work/err.txt"
  [ $rc = 2 ] || fail "expected exit 2 for '$1', got $rc"
  [ "$(grep -c "error: .*$1" "$work/err.txt")" = 1 ] || fail "expected one error naming '$1'"
}
expect_error "no element centroid lies inside" 's["material"]["inclusion"] = {"min": [9, 9, 9], "max": [10, 10, 10], "young": 5e7}'
expect_error "degree 1" 's["degree"] = 1'
expect_error "output.probe: the point (9 9 9) lies outside" 's["output"]["probe"] = [9, 9, 9]'
echo "mpi_simulate.sh: ok"
