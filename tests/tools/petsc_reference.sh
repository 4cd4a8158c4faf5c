#!/usr/bin/env bash
# petsc_reference.sh PMG PETSC_REFERENCE: pmgkit's gamg-pcg and PETSc's own KSP (CG + GAMG from its
# command line, on the system exported with --export-petsc) take the same number of iterations.
set -eu
pmg=$1 ref=$2
d=$(mktemp -d)
trap 'rm -rf "$d"' EXIT
out=$("$pmg" compare --box 6 2 2 -p 2 --tol 1e-6 --threads 1 --solvers gamg-pcg --export-petsc "$d")
printf '%s\n' "$out"
ours=$(printf '%s\n' "$out" | awk '$1 == "gamg-pcg" && $2 == "converged" {print $3}')
theirs=$(OMP_NUM_THREADS=1 "$ref" -dir "$d" -ksp_type cg -pc_type gamg -ksp_rtol 1e-6 \
  -ksp_norm_type unpreconditioned -mg_levels_ksp_type chebyshev -mg_levels_pc_type jacobi \
  -mg_levels_esteig_ksp_type cg)
printf '%s\n' "$theirs"
its=$(printf '%s\n' "$theirs" | sed -n 's/.*after \([0-9]*\) iterations.*/\1/p')
if [ -z "$ours" ] || [ "$ours" != "$its" ]; then
  echo "petsc_reference.sh: gamg-pcg took '$ours' iterations, PETSc's own KSP '$its'"
  exit 1
fi
echo "same iterations: $ours"
