"""The solver contract's cases a hostile probe found (issue #48), from Python: each is the right
answer or a named pmgkit error, never a crash, a Python-internal error or a silent cast."""
import os

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.linalg import LinearOperator

import pmgkit


def _spd(n=30, seed=1):
    """A well-conditioned SPD matrix of 3x3 blocks (symmetric, strictly diagonally dominant): a
    random node pattern with a dense 3x3 block at each entry, as a 3-component system has."""
    rng = np.random.default_rng(seed)
    S = sp.random(n // 3, n // 3, density=0.3, random_state=seed) + sp.identity(n // 3)
    M = sp.kron((S != 0).astype(float), np.ones((3, 3))).tocsr()
    M.data = rng.uniform(-1, 1, M.nnz)
    M = M + M.T
    return (M + sp.diags(np.abs(M).sum(axis=1).A1 + 1.0)).tocsr()


A = _spd()
b = np.sin(np.arange(A.shape[0]) + 1.0)


def test_a_per_call_tol_holds_for_that_call_only():
    s = pmgkit.make_solver(A, {"method": "cg", "tol": 1e-10})
    _, loose = s.solve(b, tol=1e-2)
    assert loose["residual"] <= 2e-2
    x, info = s.solve(b)
    assert info["residual"] <= 2e-10, "the next call without tol must use the config's tol again"


@pytest.mark.parametrize("method", ["cg", "block-jacobi-pcg", "mcg"])
def test_a_warm_start_at_the_answer_succeeds_at_once(method):
    s = pmgkit.make_solver(A, {"method": method, "tol": 1e-8})
    x, info = s.solve(b)
    assert info["status"] == "converged"
    x2, info2 = s.solve(b, x0=x)
    assert info2["status"] == "converged" and info2["iterations"] == 0
    assert np.array_equal(x, x2)


@pytest.mark.parametrize("scale", [1e-200, 1e200])
def test_a_right_hand_side_far_from_one_is_solved_and_scales(scale):
    s = pmgkit.make_solver(A, {"method": "cg", "tol": 1e-10})
    x, _ = s.solve(b)
    xs, info = s.solve(b * scale)
    assert info["status"] == "converged"
    assert np.linalg.norm(xs / scale - x) <= 1e-8 * np.linalg.norm(x)


def test_complex_vectors_are_refused_not_cast():
    s = pmgkit.make_solver(A, {"method": "cg"})
    for bad in (b + 1j, (b + 0j)):
        with pytest.raises(pmgkit.InputError, match="complex"):
            s.solve(bad)
    with pytest.raises(pmgkit.InputError, match="complex"):
        s.solve(b, x0=np.zeros(A.shape[0]) + 0j)


@pytest.mark.parametrize("k", [1, 2, 3])
def test_aspreconditioner_takes_blocks_of_vectors(k):
    s = pmgkit.make_solver(A, {"method": "block-jacobi"})
    M = s.aspreconditioner()
    assert isinstance(M, LinearOperator)
    X = np.column_stack([np.roll(b, j) for j in range(k)])
    Y = M @ X
    assert Y.shape == (A.shape[0], k)
    for j in range(k):
        assert np.allclose(Y[:, j], M @ X[:, j])
    assert (M @ b).shape == (A.shape[0],)
    assert (M @ b[:, None]).shape == (A.shape[0], 1)


def test_a_deeply_nested_config_is_an_input_error():
    config = {"method": "cg"}
    node = config
    for _ in range(5000):
        node["preconditioner"] = {}
        node = node["preconditioner"]
    with pytest.raises(pmgkit.InputError, match="nested deeper than"):
        pmgkit.make_solver(A, config)


def test_a_decreasing_indptr_is_named():
    bad = A.copy()
    bad.indptr = bad.indptr.copy()
    bad.indptr[3], bad.indptr[4] = bad.indptr[4], bad.indptr[3]
    with pytest.raises(pmgkit.InputError, match="row pointers decrease at row"):
        pmgkit.make_solver(bad, {"method": "cg"})


def test_cholmod_on_a_zero_matrix_names_it():
    if "cholmod" not in {m["name"] for m in pmgkit.methods()}:
        pytest.skip("no CHOLMOD in this build")
    for Z in (sp.csr_matrix((6, 6)), sp.csr_matrix(np.zeros((6, 6)))):
        with pytest.raises(pmgkit.Error, match="not positive definite"):
            pmgkit.make_solver(Z, {"method": "cholmod"}, format="csr").solve(np.ones(6))


def test_a_direct_solve_of_a_thin_plate_is_judged_by_its_backward_error():
    """A thin plate (4 x 1 x 0.02 m, 16 x 4 x 1 boxes, P2) with a deflected start: its static
    solve's residual, about eps ||A|| ||x||, is above 1e-6 ||b||, yet the answer is exact to
    rounding; it must not fail."""
    if "cholmod" not in {m["name"] for m in pmgkit.methods()}:
        pytest.skip("no CHOLMOD in this build")
    scene = {"mesh": {"box": [16, 4, 1], "size": [4.0, 1.0, 0.02]}, "degree": 2,
             "material": {"model": "linear"}, "solver": {"method": "mgpcg"},
             "initial": {"state": "deflected"}, "time": {"dt": 0.01, "duration": 0.01}}
    out = pmgkit.simulate(scene)
    assert out["steps_done"] == 1
