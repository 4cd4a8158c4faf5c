#!/usr/bin/env bash
# mpi_compare.sh PMG DATA: `pmg compare` under mpirun as a user runs it. 2 ranks give one table
# (rank 0's), one JSON report and the one-rank run's solution and iterations (within one); too few
# elements for the ranks, and a file missing on one rank only, end every rank with one clear error
# and a non-zero exit instead of a hang. Oversubscribed ranks on small cases: equality, not speed.
set -u
pmg=$1 data=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mpi=(mpirun --allow-run-as-root --oversubscribe --bind-to none -x OMP_NUM_THREADS=1)
[ -n "${ASAN_OPTIONS:-}" ] && mpi+=(-x ASAN_OPTIONS)  # the sanitizer build: Open MPI's own leaks off
fail() { echo "mpi_compare.sh: $*"; exit 1; }
scene=(compare --box 6 2 2 --size 1 0.3 0.3 --degree 3 --solvers petsc-mgpcg --tol 1e-10)

OMP_NUM_THREADS=1 "$pmg" "${scene[@]}" --json "$work/np1.json" > "$work/np1.txt" 2>&1 || { cat "$work/np1.txt"; fail "np 1 failed"; }
"${mpi[@]}" -np 2 "$pmg" "${scene[@]}" --json "$work/np2.json" > "$work/np2.txt" 2>&1 || { cat "$work/np2.txt"; fail "np 2 failed"; }
cat "$work/np2.txt"
[ "$(grep -c '^petsc-mgpcg  *converged' "$work/np2.txt")" = 1 ] || fail "expected one table row (rank 0 prints)"
grep -q "over 2 ranks" "$work/np2.txt" || fail "the solver does not say it ran on 2 ranks"
/usr/bin/python3 - "$work/np1.json" "$work/np2.json" <<'PY' || fail "np 2 differs from np 1"
import json, sys
one, two = (json.load(open(p)) for p in sys.argv[1:3])
def row(r):
    return next(s for s in r["solvers"] if s["name"] == "petsc-mgpcg")
a, b = row(one), row(two)
print("iterations", a["iterations"], b["iterations"], "errors", a["rel_error"], b["rel_error"])
assert abs(a["iterations"] - b["iterations"]) <= 1
assert a["rel_error"] < 1e-8 and b["rel_error"] < 1e-8
PY

# Too few elements for the ranks: the solver's set-up fails on every rank, rank 0 reports it.
"${mpi[@]}" -np 7 "$pmg" compare --mesh "$data/kuhn_cube.ele" --degree 2 --solvers petsc-mgpcg > "$work/few.txt" 2>&1
rc=$?
cat "$work/few.txt"
[ $rc -ne 0 ] || fail "7 ranks on 6 elements exited 0"
[ "$(grep -c 'cannot fill 7 parts' "$work/few.txt")" = 1 ] || fail "expected one 'cannot fill' message"

# A file missing on rank 1 only: rank 0 waits in a collective; rank 1's error ends the job.
timeout 120 "${mpi[@]}" -np 2 sh -c 'if [ "$OMPI_COMM_WORLD_RANK" = 1 ]; then exec "$0" compare --mesh /nonexistent.ele --degree 2 --solvers petsc-mgpcg; else exec "$0" compare --box 6 2 2 --degree 2 --solvers petsc-mgpcg; fi' "$pmg" > "$work/missing.txt" 2>&1
rc=$?
cat "$work/missing.txt"
[ $rc -ne 0 ] && [ $rc -ne 124 ] || fail "a file missing on one rank: exit code $rc (124: a hang)"
[ "$(grep -c 'pmg: error' "$work/missing.txt")" = 1 ] || fail "expected one error line"
grep -q "(rank 1) pmg: error: --mesh: File does not exist" "$work/missing.txt" || fail "the error does not name the rank and the file"
echo "mpi_compare.sh: ok"
