"""Shared fixtures: the pmgkit module from the build tree (PYTHONPATH set by CTest, or
<repo>/build/python), the pmg binary for C++ reference runs, and small elasticity systems built
with pmgkit's own BB FEM."""
import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
BUILD = pathlib.Path(os.environ.get("PMG_BUILD_DIR", ROOT / "build"))
if str(BUILD / "python") not in sys.path:
    sys.path.insert(0, str(BUILD / "python"))

import pmgkit  # noqa: E402


@pytest.fixture(scope="session")
def pmg_bin():
    path = pathlib.Path(os.environ.get("PMG_BIN", BUILD / "tools" / "pmg"))
    if not path.exists():
        pytest.skip(f"pmg binary not built ({path})")
    return path


def run_pmg(pmg_bin, *args):
    r = subprocess.run([str(pmg_bin), *map(str, args)], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr
    return r.stdout


@pytest.fixture(scope="session")
def cubic_box():
    """A clamped cubic BB cantilever (4x2x2 boxes of 24 tets, 1.8k unknowns): its degree hierarchy."""
    mesh = pmgkit.Mesh.box(4, 2, 2, 2.0, 1.0, 1.0)
    h = pmgkit.DegreeHierarchy(mesh, 3, pmgkit.Material(1e5, 0.3, 1e3), clamp=lambda x: x[0] < 1e-9)
    return mesh, h


@pytest.fixture(scope="session")
def levels(cubic_box):
    _, h = cubic_box
    return h.levels(), h.prolongations()


@pytest.fixture(scope="session")
def rhs(levels):
    A = levels[0][-1]
    return np.sin(np.arange(A.shape[0]) * 0.37) + 0.5
