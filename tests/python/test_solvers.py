"""make_solver on SciPy matrices: every route against SciPy's own results, the factory's options,
updates, the preconditioner interface, zero-copy input and the errors."""
import json

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

import pmgkit


def direct(A, b):
    return spla.spsolve(A.tocsc(), b)


@pytest.mark.parametrize("config", [
    {"method": "cg", "tol": 1e-10, "preconditioner": {"method": "block-jacobi"}},
    {"method": "block-jacobi-pcg", "tol": 1e-10},
    {"method": "mcg", "tol": 1e-10},
    {"method": "boomeramg-pcg", "tol": 1e-10},
    {"method": "cholmod"},
])
def test_solvers_reach_the_direct_solution(levels, rhs, config):
    A = levels[0][-1].tocsr()
    x_ref = direct(A, rhs)
    s = pmgkit.make_solver(A, config)
    x, info = s.solve(rhs)
    assert info["status"] in ("converged", "completed")
    true = np.linalg.norm(rhs - A @ x) / np.linalg.norm(rhs)
    # the two residuals differ by the round-off of computing one: about eps ||A|| ||x|| / ||b||
    rounding = 100 * np.finfo(float).eps * spla.norm(A, 1) * np.linalg.norm(x) / np.linalg.norm(rhs)
    assert abs(info["residual"] - true) <= rounding
    assert info["residual"] <= 1e-10 * (1 + 10 * (config["method"] == "cholmod"))
    # error bounded by the condition number times the residual; the direct solve agrees far tighter
    assert np.linalg.norm(x - x_ref) / np.linalg.norm(x_ref) < 1e-5
    if config["method"] != "cholmod":
        assert len(info["history"]) == info["iterations"] + 1
        assert info["history"][0] == 1.0
        assert np.all(np.diff(info["history_seconds"]) >= 0)
    assert info["setup_seconds"] >= 0 and info["solve_seconds"] > 0


def test_config_as_json_string_and_formats_agree(levels, rhs):
    A = levels[0][-1]
    cfg = {"method": "cg", "tol": 1e-9, "preconditioner": {"method": "jacobi"}}
    results = []
    for fmt in ("csr", "bcsr", "bin-bcsr"):
        x, info = pmgkit.make_solver(A, json.dumps(cfg), format=fmt).solve(rhs)
        results.append((x, info["iterations"]))
    # the same algorithm on three storage formats: same iterations, round-off differences only
    assert results[0][1] == results[1][1] == results[2][1]
    for x, _ in results[1:]:
        assert np.linalg.norm(x - results[0][0]) / np.linalg.norm(x) < 1e-9


def test_int32_and_int64_indices_are_read_in_place(levels):
    A = levels[0][-1].tocsr()
    A.sort_indices()
    for dtype in (np.int32, np.int64):
        B = sp.csr_matrix((A.data, A.indices.astype(dtype), A.indptr.astype(dtype)), shape=A.shape)
        arrays = pmgkit._csr_arrays(B)
        addr = pmgkit._core._view_addresses(arrays)
        assert addr == (B.indptr.ctypes.data, B.indices.ctypes.data, B.data.ctypes.data)
        x, _ = pmgkit.make_solver(B, {"method": "cholmod"}).solve(np.ones(A.shape[0]))
        assert np.isfinite(x).all()


def test_other_scipy_formats_and_unsorted_indices(levels, rhs):
    A = levels[0][-1].tocsr()
    x_ref, _ = pmgkit.make_solver(A, {"method": "cholmod"}).solve(rhs)
    coo = A.tocoo()
    perm = np.random.default_rng(1).permutation(coo.nnz)
    shuffled = sp.coo_matrix((coo.data[perm], (coo.row[perm], coo.col[perm])), shape=A.shape)
    unsorted = sp.csr_matrix((A.data.copy(), A.indices.copy(), A.indptr.copy()), shape=A.shape)
    for r in range(0, A.shape[0], 7):  # reverse some rows: no longer canonical
        a, b = unsorted.indptr[r], unsorted.indptr[r + 1]
        unsorted.indices[a:b] = unsorted.indices[a:b][::-1].copy()
        unsorted.data[a:b] = unsorted.data[a:b][::-1].copy()
    unsorted.has_sorted_indices = False
    for M in (A.tocsc(), shuffled, A.tobsr(blocksize=(3, 3)), unsorted):
        x, _ = pmgkit.make_solver(M, {"method": "cholmod"}).solve(rhs)
        assert np.linalg.norm(x - x_ref) / np.linalg.norm(x_ref) < 1e-12


def test_update_refreshes_values_on_the_same_pattern(levels, rhs):
    A = levels[0][-1].tocsr()
    for cfg in ({"method": "cholmod"}, {"method": "block-jacobi-pcg", "tol": 1e-10}):
        s = pmgkit.make_solver(A, cfg)
        x1, i1 = s.solve(rhs)
        s.update(2.0 * A)
        x2, i2 = s.solve(rhs)
        assert np.linalg.norm(2.0 * x2 - x1) / np.linalg.norm(x1) < 1e-8
        assert i1["iterations"] == i2["iterations"]
    s = pmgkit.make_solver(A, {"method": "cholmod"})
    C = A.copy()
    C.setdiag(C.diagonal() * 0)  # drops nothing: explicit zeros keep the pattern
    C.eliminate_zeros()           # now the pattern differs
    with pytest.raises(pmgkit.InputError, match="pattern"):
        s.update(C)


def test_as_preconditioner_in_scipy_cg(levels, rhs):
    A = levels[0][-1].tocsr()
    counts = {}
    for name, M in (("none", None),
                    ("block-jacobi", pmgkit.make_solver(A, {"method": "block-jacobi"}).aspreconditioner())):
        it = [0]
        x, ok = spla.cg(A, rhs, M=M, tol=1e-8, maxiter=20000, callback=lambda _: it.__setitem__(0, it[0] + 1))
        assert ok == 0
        counts[name] = it[0]
        assert np.linalg.norm(rhs - A @ x) / np.linalg.norm(rhs) < 1e-8 * 1.01
    assert counts["block-jacobi"] < counts["none"]
    # pmgkit's own CG with the same preconditioner takes as many iterations (same algorithm)
    _, info = pmgkit.make_solver(A, {"method": "cg", "tol": 1e-8, "preconditioner": {"method": "block-jacobi"}}).solve(rhs)
    assert abs(info["iterations"] - counts["block-jacobi"]) <= 2


def test_x0_and_tol(levels, rhs):
    A = levels[0][-1].tocsr()
    s = pmgkit.make_solver(A, {"method": "block-jacobi-pcg", "tol": 1e-4})
    x, info = s.solve(rhs)
    _, info_warm = s.solve(rhs, x0=x)
    assert info_warm["iterations"] < info["iterations"]
    _, info_tight = s.solve(rhs, tol=1e-10)
    assert info_tight["residual"] < 1e-10 and info_tight["iterations"] > info["iterations"]


def test_errors_carry_the_library_messages(levels, rhs):
    A = levels[0][-1].tocsr()
    with pytest.raises(pmgkit.InputError, match="not_a_key"):
        pmgkit.make_solver(A, {"method": "cg", "not_a_key": 1})
    with pytest.raises(pmgkit.InputError, match="unknown|method"):
        pmgkit.make_solver(A, {"method": "no-such-method"})
    with pytest.raises(pmgkit.InputError, match="square"):
        pmgkit.make_solver(sp.random(6, 9, density=0.5, format="csr"), {"method": "cg"})
    with pytest.raises(pmgkit.InputError, match="symmetric"):
        pmgkit.make_solver(sp.csr_matrix(np.triu(np.ones((6, 6)))), {"method": "cg"})
    with pytest.raises(pmgkit.InputError, match="shape"):
        pmgkit.make_solver(A, {"method": "cholmod"}).solve(np.ones(5))
    with pytest.raises(pmgkit.InputError, match="non-finite"):
        B = A.copy()
        B.data[0] = np.nan
        pmgkit.make_solver(B, {"method": "cholmod"})
    with pytest.raises(ValueError):  # InputError is a ValueError
        pmgkit.make_solver("not a matrix")
    # not positive definite: CG breaks down, CHOLMOD refuses
    neg = -A
    with pytest.raises(pmgkit.SolveError, match="positive definite|breakdown"):
        pmgkit.make_solver(neg, {"method": "cg", "tol": 1e-8}).solve(rhs)
    with pytest.raises(pmgkit.Error, match="positive definite"):
        pmgkit.make_solver(neg, {"method": "cholmod"})
    # stagnation / iteration limit: a solve that cannot reach its tolerance says so
    with pytest.raises(pmgkit.SolveError, match="iteration"):
        pmgkit.make_solver(A, {"method": "cg", "tol": 1e-12, "max_iterations": 3}).solve(rhs)
    assert issubclass(pmgkit.SolveError, pmgkit.Error) and issubclass(pmgkit.InputError, pmgkit.Error)


def test_methods_lists_the_factory():
    names = [m["name"] for m in pmgkit.methods()]
    for n in ("cg", "mgpcg", "pmg", "cholmod", "boomeramg", "block-jacobi"):
        assert n in names


def test_the_gil_is_released_during_solves():
    """Another Python thread runs while a solve is inside C++."""
    import threading
    import time
    # 262k unknowns to 1e-12: about half a second on a 2-core VM, many switch intervals (5 ms) long
    # on any machine (at n = 40 the solve once took 0.08 s, too short to tell)
    n = 64
    T = sp.diags([-np.ones(n - 1), 2.0 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1])
    I = sp.identity(n)
    A = (sp.kron(sp.kron(T, I), I) + sp.kron(sp.kron(I, T), I) + sp.kron(sp.kron(I, I), T)).tocsr()
    b = np.ones(A.shape[0])
    s = pmgkit.make_solver(A, {"method": "cg", "tol": 1e-12}, format="csr")
    state = {"in_call": False, "seconds": 0.0}

    def solve():
        state["in_call"] = True
        t0 = time.perf_counter()
        s.solve(b)
        state["seconds"] = time.perf_counter() - t0
        state["in_call"] = False

    t0, ticks = time.perf_counter(), 0
    while time.perf_counter() - t0 < 0.05:  # the loop's own rate, alone
        ticks += 1
    rate = ticks / (time.perf_counter() - t0)
    t = threading.Thread(target=solve)
    t.start()
    during = 0
    while t.is_alive():
        if state["in_call"]:
            during += 1
    t.join()
    assert state["seconds"] > 0.1, ("the solve is too short to tell", state["seconds"])
    # a held GIL would let the loop run at most about one switch interval (5 ms) of the call; a
    # released one lets it run through the call (slowed by the solver's threads on this machine)
    import sys
    assert during > 4 * sys.getswitchinterval() * rate, (during, rate, state["seconds"])


def test_a_key_given_twice_is_refused():
    """A dotted key beside the same key inside its section: an error, not the last one winning."""
    A = sp.diags([-np.ones(29), 2.5 * np.ones(30), -np.ones(29)], [-1, 0, 1], format="csr")
    with pytest.raises(pmgkit.InputError, match="preconditioner.method: given twice"):
        pmgkit.make_solver(A, {"method": "cg", "preconditioner.method": "jacobi",
                               "preconditioner": {"method": "block-jacobi"}})
