#!/usr/bin/env bash
# mpi_distributed_mesh.sh PMG DATA: `pmg compare --distributed-mesh` under mpirun as a user runs it.
# A bar refined once on the ranks after distribution: 1, 2 and 3 ranks give one report each (rank
# 0's), one JSON report, the same compliance bᵀu and largest displacement to 1e-8 and iterations
# within one; --history writes the residual per iteration; the refined mesh saved in PETSc's HDF5
# format and read back in parallel gives the same answer; a quarter model with two symmetry planes
# gives the serial MGPCG's compliance on 1-3 ranks; the options the route cannot honour, too
# few cells for the ranks, a mesh file missing or unreadable and an output that is an input end
# every rank with one clear error and exit code 2 instead of a hang.
# Oversubscribed ranks on small cases: equality, not speed.
set -u
pmg=$1 data=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mpi=(mpirun --allow-run-as-root --oversubscribe --bind-to none -x OMP_NUM_THREADS=1)
[ -n "${ASAN_OPTIONS:-}" ] && mpi+=(-x ASAN_OPTIONS)  # the sanitizer build: Open MPI's own leaks off
fail() { echo "mpi_distributed_mesh.sh: $*"; exit 1; }
scene=(compare --box 4 2 2 --size 1 0.5 0.5 --degree 2 --fix x --load traction --refine 1 --tol 1e-11 --distributed-mesh)

for np in 1 2 3; do
  "${mpi[@]}" -np $np "$pmg" "${scene[@]}" --json "$work/np$np.json" > "$work/np$np.txt" 2>&1 ||
    { cat "$work/np$np.txt"; fail "np $np failed"; }
  [ "$(grep -c '^petsc-mgpcg: converged' "$work/np$np.txt")" = 1 ] || { cat "$work/np$np.txt"; fail "np $np: expected one report"; }
  grep -Eq "over $np ranks|on 1 rank" "$work/np$np.txt" || fail "np $np: the report does not name the ranks"
done
cat "$work/np3.txt"
/usr/bin/python3 - "$work"/np1.json "$work"/np2.json "$work"/np3.json <<'PY' || fail "the ranks' answers differ"
import json, sys
runs = [json.load(open(p)) for p in sys.argv[1:]]
one = runs[0]
assert one["tets"] == 4 * 2 * 2 * 24 * 8, one["tets"]  # 4x2x2 boxes of 24 tets, refined once
for r in runs:
    print(r["ranks"], "ranks:", r["iterations"], "iterations, compliance", r["compliance (J)"],
          "largest displacement", r["largest displacement (m)"], "true residual", r["true_relative_residual"])
    assert r["converged"] and r["true_relative_residual"] < 1e-10
    assert r["unknowns"] == one["unknowns"] and r["tets"] == one["tets"]
    assert abs(r["iterations"] - one["iterations"]) <= 1
    assert abs(r["compliance (J)"] - one["compliance (J)"]) <= 1e-8 * abs(one["compliance (J)"])
    assert abs(r["largest displacement (m)"] - one["largest displacement (m)"]) <= 1e-8 * one["largest displacement (m)"]
    assert len(r["peak resident memory per rank (bytes)"]) == r["ranks"]
    assert sum(g["owned"] for g in r["finest level ghost/owned nodes per rank"]) * 3 == r["unknowns"]
PY

# --history: rank 0 writes the residual per iteration, as pmg compare does for every solver.
"${mpi[@]}" -np 2 "$pmg" "${scene[@]}" --history "$work/h.csv" --json "$work/h.json" > "$work/h.txt" 2>&1 ||
  { cat "$work/h.txt"; fail "--history failed"; }
/usr/bin/python3 - "$work/h.csv" "$work/h.json" <<'PY' || fail "the history does not match the solve"
import csv, json, sys
rows = list(csv.DictReader(open(sys.argv[1])))
report = json.load(open(sys.argv[2]))
assert [r["iteration"] for r in rows] == [str(i) for i in range(report["iterations"] + 1)], rows
assert all(r["solver"] == "petsc-mgpcg" for r in rows)
assert float(rows[0]["rel_residual"]) == 1.0 and float(rows[-1]["rel_residual"]) <= 1e-11
seconds = [float(r["seconds"]) for r in rows]
assert seconds == sorted(seconds)
print(len(rows), "history rows")
PY

# The refined mesh saved in PETSc's HDF5 format on 2 ranks, read back in parallel on 3: the same
# problem, the same answer.
"${mpi[@]}" -np 2 "$pmg" "${scene[@]}" --save-mesh "$work/fine.h5" > "$work/save.txt" 2>&1 ||
  { cat "$work/save.txt"; fail "--save-mesh failed"; }
[ -s "$work/fine.h5" ] && [ ! -e "$work/fine.h5.part" ] || fail "--save-mesh left no complete file"
read_back=(compare --mesh "$work/fine.h5" --degree 2 --fix x --load traction --tol 1e-11 --distributed-mesh)
"${mpi[@]}" -np 3 "$pmg" "${read_back[@]}" --json "$work/h5.json" > "$work/h5.txt" 2>&1 ||
  { cat "$work/h5.txt"; fail "reading the .h5 mesh failed"; }
grep -q "read in parallel" "$work/h5.txt" || fail "the .h5 mesh was not read in parallel"
/usr/bin/python3 - "$work"/np1.json "$work"/h5.json <<'PY' || fail "the mesh read back gives another answer"
import json, sys
a, b = (json.load(open(p)) for p in sys.argv[1:3])
print("made and refined:", a["compliance (J)"], "read back:", b["compliance (J)"])
assert a["tets"] == b["tets"] and a["unknowns"] == b["unknowns"]
assert abs(a["compliance (J)"] - b["compliance (J)"]) <= 1e-8 * abs(a["compliance (J)"])
PY

# A quarter model with two symmetry planes: the serial MGPCG's compliance on 1, 2 and 3 ranks.
quarter=(compare --box 4 2 2 --size 1 0.25 0.25 --degree 2 --fix x --load traction --symmetry y:max --symmetry z:max
         --tol 1e-11)
OMP_NUM_THREADS=1 "$pmg" "${quarter[@]}" --solvers mgpcg --no-reference --json "$work/q_serial.json" > "$work/q.txt" 2>&1 ||
  { cat "$work/q.txt"; fail "the serial quarter model failed"; }
for np in 1 2 3; do
  "${mpi[@]}" -np $np "$pmg" "${quarter[@]}" --distributed-mesh --json "$work/q$np.json" > "$work/q$np.txt" 2>&1 ||
    { cat "$work/q$np.txt"; fail "the quarter model on $np ranks failed"; }
  grep -q "components held by symmetry planes" "$work/q$np.txt" || fail "np $np: the report does not count the held components"
done
/usr/bin/python3 - "$work"/q_serial.json "$work"/q1.json "$work"/q2.json "$work"/q3.json <<'PY' || fail "the quarter model differs"
import json, sys
serial = json.load(open(sys.argv[1]))
row = [r for r in serial["solvers"] if r["name"] == "mgpcg"][0]
ref = row["b_dot_x"]
its = []
for p in sys.argv[2:]:
    r = json.load(open(p))
    print(r["ranks"], "ranks: compliance", r["compliance (J)"], "serial", ref, "iterations", r["iterations"])
    assert abs(r["compliance (J)"] - ref) <= 1e-8 * abs(ref)
    its.append(r["iterations"])
assert max(its) - min(its) <= 1, its
PY

# Options the route cannot honour: one error, exit 2, on every rank.
expect_error() {  # expect_error NP PATTERN ARGS...: exit 2 (bad input), one error line matching
  local np=$1 pattern=$2
  shift 2
  timeout 120 "${mpi[@]}" -np "$np" "$pmg" "$@" > "$work/err.txt" 2>&1
  local rc=$?
  cat "$work/err.txt"
  [ $rc -eq 2 ] || fail "$*: exit code $rc, expected 2 (bad input; 124: a hang)"
  [ "$(grep -c 'pmg: error' "$work/err.txt")" = 1 ] || fail "$*: expected one error line"
  grep -q -- "$pattern" "$work/err.txt" || fail "$*: the error does not say '$pattern'"
  ! grep -q "HDF5-DIAG" "$work/err.txt" || fail "$*: HDF5's own error stack printed"
}
expect_error 2 "runs petsc-mgpcg only" "${scene[@]}" --solvers mgpcg
expect_error 2 "does not take --dt" "${scene[@]}" --dt 0.01
expect_error 2 "the sparse Cholesky is 'mumps'" "${scene[@]}" --set lowest_level=cholmod
expect_error 2 "degree 1 (2 or 3)" compare --box 4 2 2 --degree 1 --fix x --distributed-mesh
expect_error 7 "6 cells for 7 ranks" compare --mesh "$data/kuhn_cube.ele" --degree 2 --fix x --distributed-mesh
expect_error 2 "File does not exist" compare --mesh /nonexistent.ele --degree 2 --fix x --distributed-mesh
expect_error 2 "a name ending in .h5" "${scene[@]}" --save-mesh "$work/fine.vtu"
expect_error 2 "needs --distributed-mesh" compare --box 4 2 2 --degree 2 --save-mesh "$work/x.h5"
expect_error 2 "--json" "${read_back[@]}" --json "$work/fine.h5"
printf 'not HDF5' > "$work/junk.h5"
expect_error 2 "not an HDF5 file" compare --mesh "$work/junk.h5" --degree 2 --fix x --distributed-mesh
echo "mpi_distributed_mesh.sh: ok"
