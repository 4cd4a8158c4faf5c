"""pmgkit.study: pmg compare's study layer from Python, on a matrix and on an FEM hierarchy."""
import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

import pmgkit


def lattice(n):
    """The 3-D 7-point Laplacian on n^3 nodes plus a shift: SPD, size divisible by 3 when n is."""
    T = sp.diags([-np.ones(n - 1), 2.0 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1])
    I = sp.identity(n)
    A = sp.kron(sp.kron(T, I), I) + sp.kron(sp.kron(I, T), I) + sp.kron(sp.kron(I, I), T)
    return (A + 0.1 * sp.identity(n ** 3)).tocsr()


def test_a_study_runs_each_solver_in_order_and_measures_time_residual_and_error():
    A = lattice(6)
    x_ref = np.linspace(1.0, 2.0, A.shape[0])
    b = A @ x_ref
    runs = pmgkit.study(A, b, {"plain": {"method": "cg", "tol": 1e-10},
                               "jacobi": {"method": "jacobi-pcg", "tol": 1e-10},
                               "direct": {"method": "cholmod"}}, reference=x_ref)
    assert [r["name"] for r in runs] == ["plain", "jacobi", "direct"]
    for r in runs:
        assert r["status"] in ("converged", "completed"), r
        assert r["message"] == ""
        assert r["rel_error"] <= 1e-8, r
        assert r["b_dot_x"] == pytest.approx(b @ x_ref, rel=1e-8)  # bᵀx of the answer
        assert r["setup_seconds"] >= 0 and r["solve_seconds"] >= 0
        assert r["config"].startswith("method=")
    cg = runs[0]
    assert cg["iterations"] == len(cg["history"]) - 1  # the initial residual is record 0
    assert cg["history"][-1] <= 1e-10
    assert np.all(np.diff(cg["history_seconds"]) >= 0)
    # time_to: set-up plus the time the history first reached the level.
    reached = np.argmax(cg["history"] <= 1e-6)
    assert cg["time_to_1e-6"] == pytest.approx(cg["setup_seconds"] + cg["history_seconds"][reached])
    # The same solver run on its own gives the same iterations.
    x, info = pmgkit.make_solver(A, {"method": "cg", "tol": 1e-10}).solve(b)
    assert info["iterations"] == cg["iterations"]
    # Methods as a list; no reference: no error.
    runs = pmgkit.study(A, b, ["cg", "jacobi-pcg"])
    assert [r["name"] for r in runs] == ["cg", "jacobi-pcg"] and runs[0]["rel_error"] is None
    # The lattice is a scalar system (its size a multiple of 3): a block method is refused up front.
    with pytest.raises(pmgkit.InputError, match="scalar system"):
        pmgkit.study(A, b, ["cg", "block-jacobi-pcg"])


def test_a_study_refuses_what_it_cannot_run():
    A = lattice(3)
    b = np.ones(A.shape[0])
    with pytest.raises(pmgkit.InputError, match="bogus"):
        pmgkit.study(A, b, {"cg": {"method": "cg", "bogus": 1}})
    with pytest.raises(pmgkit.InputError, match="solvers"):
        pmgkit.study(A, b, {})
    with pytest.raises(pmgkit.InputError, match="format"):
        pmgkit.study(A, b, ["cg"], format="ell")
    with pytest.raises(pmgkit.InputError):
        pmgkit.study(A, np.ones(5), ["cg"])
    # A failed solver is a status in its row, not an exception of the study.
    runs = pmgkit.study(A, b, {"short": {"method": "cg", "tol": 1e-14, "max_iterations": 1}})
    assert runs[0]["status"] != "converged" and runs[0]["message"]


def test_a_study_on_a_hierarchy_binds_each_solver_to_its_levels():
    mesh = pmgkit.Mesh.box(3, 1, 1, 3.0, 1.0, 1.0)
    h = pmgkit.DegreeHierarchy(mesh, 3, pmgkit.Material(5e5, 0.3, 1000.0), lambda X: X[0] < 1e-9)
    b = h.restrict_to_free(h.gravity([0.0, 0.0, -9.81]))
    K = h.levels()[-1]
    exact = spla.spsolve(K.tocsc(), b)
    runs = pmgkit.study(h, b, {"mgpcg": {"tol": 1e-10}, "assembled": {"method": "pmg", "operator": "assembled",
                                                                         "tol": 1e-10},
                               "cg": {"method": "cg", "tol": 1e-10, "max_iterations": 5000}}, reference=exact)
    for r in runs:
        assert r["status"] == "converged", r
        assert r["rel_error"] <= 1e-7, r
    assert "matrix-free" in runs[0]["setup_breakdown"]  # its levels' preparation charged to its set-up


def test_a_study_of_a_scene_is_pmg_compares_system():
    scene = {"mesh": {"box": [3, 1, 1], "size": [3, 1, 1]}, "degree": 2, "time": "static",
             "material": {"young": 5e5, "poisson": 0.3, "density": 1000}, "loads": {"gravity": [0, 0, -9.81]}}
    runs = pmgkit.study_scene(scene, {"mgpcg": {"tol": 1e-10}, "cg": {"method": "block-jacobi-pcg", "tol": 1e-10}})
    for r in runs:
        assert r["status"] == "converged", r
        assert r["rel_error"] <= 1e-7, r  # against the direct solve of the same system
    # One implicit-Euler step's system (M + dt^2 K): better conditioned, fewer iterations.
    step = pmgkit.study_scene(scene, ["mgpcg"], dt=0.01, reference=None)
    assert step[0]["status"] == "converged" and step[0]["rel_error"] is None
    assert step[0]["iterations"] < runs[0]["iterations"]
    with pytest.raises(pmgkit.InputError):
        pmgkit.study_scene(scene, ["mgpcg"], reference="exact")
    with pytest.raises(pmgkit.InputError, match="degree"):
        pmgkit.study_scene(dict(scene, degree=7), ["mgpcg"])
