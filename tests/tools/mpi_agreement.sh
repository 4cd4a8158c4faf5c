#!/usr/bin/env bash
# mpi_agreement.sh PMG SCENE: ranks given different commands or inputs stop together with one
# named error and a non-zero exit, never a hang or a wrong answer (each case under a timeout; 124
# would be a hang). MPMD launches (`-np 1 A : -np 1 B`) give each rank its own command line.
set -u
pmg=$1 scene=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mpi=(timeout 120 mpirun --allow-run-as-root --oversubscribe --bind-to none -x OMP_NUM_THREADS=1)
[ -n "${ASAN_OPTIONS:-}" ] && mpi+=(-x ASAN_OPTIONS)
fail() { echo "mpi_agreement.sh: $*"; exit 1; }
box=(compare --box 4 2 2 --size 1 0.3 0.3 --degree 2 --fix x --load gravity --no-reference)

# expect CODE WORDS -- command...: exit code CODE, exactly one error line, holding WORDS.
expect() {
  local code=$1 words=$2
  shift 3
  "$@" > "$work/out.txt" 2>&1
  local rc=$?
  cat "$work/out.txt"
  [ $rc -ne 124 ] || fail "hang: $*"
  [ $rc -eq "$code" ] || fail "exit code $rc, expected $code: $*"
  [ "$(grep -c 'pmg: error' "$work/out.txt")" = 1 ] || fail "expected one error line: $*"
  grep -qF -- "$words" "$work/out.txt" || fail "the error does not say '$words': $*"
}

expect 2 "the ranks disagree on --poisson: rank 0 has '0.3', rank 1 has '0.2'" -- \
  "${mpi[@]}" -np 1 "$pmg" "${box[@]}" --solvers petsc-mgpcg --poisson 0.3 : -np 1 "$pmg" "${box[@]}" --solvers petsc-mgpcg --poisson 0.2
expect 2 "the ranks disagree on --set: rank 0 lacks it, rank 1 has 'options=-ksp_type nonexist'" -- \
  "${mpi[@]}" -np 1 "$pmg" "${box[@]}" --solvers petsc-mgpcg : -np 1 "$pmg" "${box[@]}" --solvers petsc-mgpcg --set "options=-ksp_type nonexist"
expect 2 "the ranks disagree on --solvers" -- \
  "${mpi[@]}" -np 1 "$pmg" "${box[@]}" --solvers petsc-mgpcg : -np 1 "$pmg" "${box[@]}" --solvers cg
expect 2 "the ranks disagree on --tol: rank 0 has '1e-6', rank 1 has '1e-8'" -- \
  "${mpi[@]}" -np 1 "$pmg" "${box[@]}" --solvers petsc-mgpcg --tol 1e-6 : -np 1 "$pmg" "${box[@]}" --solvers petsc-mgpcg --tol 1e-8
expect 2 "the ranks disagree on --dt" -- \
  "${mpi[@]}" -np 1 "$pmg" simulate "$scene" -q --duration 0.03 --dt 0.01 : -np 1 "$pmg" simulate "$scene" -q --duration 0.03 --dt 0.015
# The same command with an option nobody reads: the solver's set-up fails on every rank alike, its
# row says so once (rank 0 prints) and the run exits 1, as for any failed solver of a comparison.
expect_row() {
  local words=$1
  shift 2
  "$@" > "$work/out.txt" 2>&1
  local rc=$?
  cat "$work/out.txt"
  [ $rc -ne 124 ] || fail "hang: $*"
  [ $rc -eq 1 ] || fail "exit code $rc, expected 1: $*"
  [ "$(grep -cF -- "$words" "$work/out.txt")" = 1 ] || fail "expected '$words' once: $*"
}
expect_row "PETSc read none of the options '-bogus_option'" -- \
  "${mpi[@]}" -np 2 "$pmg" "${box[@]}" --solvers petsc-mgpcg --set "options=-bogus_option 3"
expect_row "'ksp_type' is not an option" -- \
  "${mpi[@]}" -np 2 "$pmg" "${box[@]}" --solvers petsc-mgpcg --set "options=ksp_type cg"
# A scene key petsc-mgpcg does not read, across ranks.
/usr/bin/python3 - "$scene" "$work/bogus.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
s["solver"] = {"method": "petsc-mgpcg", "bogus": 1, "precision": "single"}
json.dump(s, open(sys.argv[2], "w"))
PY
expect 2 "unknown or unused keys bogus, precision" -- "${mpi[@]}" -np 2 "$pmg" simulate "$work/bogus.json" -q --duration 0.02
echo "mpi_agreement.sh: ok"
