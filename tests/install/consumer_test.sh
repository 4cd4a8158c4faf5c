#!/usr/bin/env bash
# Installs the build tree into a temporary prefix and builds examples/consumer against it with
# find_package(pmgkit), then runs the consumer. Arguments: BUILD_DIR SOURCE_DIR.
set -euo pipefail
build=$1 src=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cmake --install "$build" --prefix "$work/prefix" > "$work/install.log"
cmake -S "$src/examples/consumer" -B "$work/consumer" -DCMAKE_PREFIX_PATH="$work/prefix" \
  -DCMAKE_BUILD_TYPE=Release > "$work/configure.log"
cmake --build "$work/consumer" > "$work/build.log"
"$work/consumer/consumer"
"$work/consumer/core_consumer"
# The core's consumer loads no MPI, hypre, PETSc or CHOLMOD library, not even indirectly.
deps=$(ldd "$work/consumer/core_consumer")
if printf '%s\n' "$deps" | grep -Eiq 'libmpi|libpetsc|libHYPRE|libcholmod|libpmg_(mpi|hypre|petsc|cholmod|multigrid)'; then
  printf '%s\n' "$deps"
  echo "consumer_test: a consumer of pmg::sparse loads MPI, hypre, PETSc or CHOLMOD"
  exit 1
fi
echo "core consumer: no MPI, hypre, PETSc or CHOLMOD among its $(printf '%s\n' "$deps" | wc -l) libraries"
# The Python module, where it was built: importable from the prefix's site-packages and working.
pydir=$(sed -n 's/^PMG_PYTHON_INSTALL_DIR:STRING=//p' "$build/CMakeCache.txt")
if [ -n "$pydir" ] && [ -d "$work/prefix/$pydir/pmgkit" ]; then
  PYTHONPATH="$work/prefix/$pydir" /usr/bin/python3 - <<'PY'
import numpy as np, pmgkit, scipy.sparse as sp
assert pmgkit.__file__.find("/prefix/") > 0, pmgkit.__file__
A = sp.diags([-np.ones(29), 2.5 * np.ones(30), -np.ones(29)], [-1, 0, 1], format="csr")
x, info = pmgkit.make_solver(A, {"method": "cg", "tol": 1e-12}).solve(np.ones(30))
assert info["residual"] < 1e-12, info
print("installed Python module: cg converged in", info["iterations"], "iterations")
PY
fi
