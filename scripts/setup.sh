#!/usr/bin/env bash
# Installs the Debian 12 packages pmgkit builds against. Idempotent: packages already present are
# left alone, and apt is not touched at all when nothing is missing.
set -euo pipefail
packages=(
  build-essential cmake pkg-config
  libeigen3-dev            # dense/sparse linear algebra, the public vector type
  libsuitesparse-dev       # CHOLMOD (supernodal sparse Cholesky)
  libopenblas0-pthread     # BLAS for CHOLMOD's supernodes (about 3x the reference BLAS)
  libhypre-dev             # BoomerAMG baseline (brings OpenMPI's headers and libraries)
  libpetsc-real-dev        # PETSc's GAMG, MUMPS and CHOLMOD baselines (optional for the build; ~20 s)
  libmetis-dev             # METIS: the element partition of the distributed p-multigrid
  openmpi-bin              # mpirun, for the 2-rank BoomerAMG test (a Recommends only)
  catch2                   # unit tests (v2)
  libbenchmark-dev         # Google Benchmark
  libcli11-dev             # command-line parsing for the pmg tool
  nlohmann-json3-dev       # JSON (scene files, reports)
  python3-vtk9             # tests read our .vtu output with a real VTK reader (Debian's python3)
  tetgen                   # pmg mesh: closed surface -> tetrahedral mesh
  libcgal-dev              # pmg mesh: surface decimation before TetGen (header-only)
  python3-matplotlib       # pmg compare --plot and pmg render (Debian's /usr/bin/python3)
  python3-pil              # pmg render: the animated GIF
  python3-dev pybind11-dev # the Python module pmgkit (python/)
  python3-numpy python3-scipy python3-pytest  # its arrays, SciPy matrices and its test suite
  python3-hypothesis       # property-based tests of the solver contract (tests/python/test_contract.py)
  python3-mpi4py           # pmgkit on MPI communicators from Python (tests/python/mpi_ranks.py)
  doxygen                  # the API reference (target doc) and its check (every public API documented)
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} packages present"
  exit 0
fi
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
echo "setup: installing ${missing[*]}"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
