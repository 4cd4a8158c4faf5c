#!/usr/bin/env bash
# Installs the build tree into a temporary prefix and builds examples/consumer against it with
# find_package(pmgkit), then runs the consumer. Arguments: BUILD_DIR SOURCE_DIR.
set -euo pipefail
build=$1 src=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# The build folder as it was before: scripts/install.sh moves CMake's install_manifest.txt away.
had_manifest=$([ -e "$build/install_manifest.txt" ] && echo yes || echo no)
"$src/scripts/install.sh" "$work/prefix" "$build" > "$work/install.log"
if [ "$had_manifest" = no ] && [ -e "$build/install_manifest.txt" ]; then
  echo "consumer_test: scripts/install.sh left install_manifest.txt in the build folder"
  exit 1
fi
[ -f "$work/prefix/share/pmgkit/install_manifest.txt" ] || { echo "consumer_test: no manifest in the prefix"; exit 1; }
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
# A consumer of pmg::sparse alone configures without MPI (as on a machine without it).
cat > "$work/core.cmake" <<'CM'
cmake_minimum_required(VERSION 3.20)
project(pmgkit_core_consumer LANGUAGES CXX)
find_package(pmgkit 0.2 REQUIRED)
add_executable(core_consumer core.cpp)
target_link_libraries(core_consumer PRIVATE pmg::sparse)
CM
mkdir -p "$work/core_src"
cp "$src/examples/consumer/core.cpp" "$work/core_src/"
cp "$work/core.cmake" "$work/core_src/CMakeLists.txt"
cmake -S "$work/core_src" -B "$work/core_nompi" -DCMAKE_PREFIX_PATH="$work/prefix" \
  -DCMAKE_DISABLE_FIND_PACKAGE_MPI=TRUE -DCMAKE_BUILD_TYPE=Release > "$work/core_configure.log" ||
  { cat "$work/core_configure.log"; echo "consumer_test: pmg::sparse alone needs MPI at configure time"; exit 1; }
cmake --build "$work/core_nompi" > "$work/core_build.log"
"$work/core_nompi/core_consumer"
# The build tree itself is a package: find_package(pmgkit) with CMAKE_PREFIX_PATH at it.
cmake -S "$src/examples/consumer" -B "$work/from_build" -DCMAKE_PREFIX_PATH="$(cd "$build" && pwd)" \
  -DCMAKE_BUILD_TYPE=Release > "$work/from_build.log" ||
  { cat "$work/from_build.log"; echo "consumer_test: find_package(pmgkit) from the build tree failed"; exit 1; }
cmake --build "$work/from_build" > "$work/from_build_build.log"
"$work/from_build/core_consumer"
echo "build tree: find_package(pmgkit) and a consumer built and ran"
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
