"""The threading contract from Python: the GIL is released during solves, so threads really run at
once. Solvers of their own on each thread, and one solver shared by several (its calls serialised),
answer as they do alone; the MPI-based libraries (MUMPS and GAMG through PETSc, BoomerAMG) too."""
import concurrent.futures

import numpy as np
import pytest

import pmgkit

METHODS = ["cg", "block-jacobi-pcg", "mcg", "cholmod", "boomeramg-pcg", "gamg-pcg", "mumps"]


def _available(method):
    info = {m["name"]: m for m in pmgkit.methods()}
    return method in info


def _rhs(n, k):
    return np.sin(np.arange(n) * (0.37 + 0.11 * k)) + 0.5


def _true_residual(A, b, x):
    return np.linalg.norm(b - A @ x) / np.linalg.norm(b)


def _system(levels, method):
    """The cubic bar's finest matrix and the method's config (iterative ones to 1e-10)."""
    if not _available(method):
        pytest.skip(method + " is not in this build")
    cfg = {"method": method} if method in ("cholmod", "mumps") else {"method": method, "tol": 1e-10}
    return levels[0][-1].tocsr(), cfg


def _run_together(n, work):
    with concurrent.futures.ThreadPoolExecutor(max_workers=n) as pool:
        return list(pool.map(work, range(n)))


@pytest.mark.parametrize("method", METHODS)
def test_own_solvers_on_threads_answer_as_alone(levels, method):
    A, cfg = _system(levels, method)
    alone = [pmgkit.make_solver(A, cfg).solve(_rhs(A.shape[0], k))[0] for k in range(3)]

    def work(t):
        s = pmgkit.make_solver(A, cfg)  # built and set up on this thread
        return [s.solve(_rhs(A.shape[0], k)) for k in range(3)]

    for results in _run_together(4, work):
        for k, (x, info) in enumerate(results):
            assert info["status"] in ("converged", "completed"), info["message"]
            assert _true_residual(A, _rhs(A.shape[0], k), x) < 1e-8
            assert np.linalg.norm(x - alone[k]) <= 1e-7 * np.linalg.norm(alone[k])


@pytest.mark.parametrize("method", METHODS)
def test_a_shared_solver_serialises_solves_updates_and_applies(levels, method):
    A, cfg = _system(levels, method)
    s = pmgkit.make_solver(A, cfg)
    n = A.shape[0]

    def work(t):
        out = []
        for k in range(3):
            b = _rhs(n, (t + k) % 4)
            x, info = s.solve(b)
            out.append((b, x, info))
            if t == 0 and k == 1:
                s.update(A)  # the same values again, while the other threads solve
            assert np.all(np.isfinite(s(b)))  # x = M b, as a preconditioner
        return out

    for results in _run_together(4, work):
        for b, x, info in results:
            assert info["status"] in ("converged", "completed"), info["message"]
            assert _true_residual(A, b, x) < 1e-8


def test_a_shared_solver_rebuilt_for_a_new_tol_by_one_thread_stays_whole(levels):
    """solve(tol=...) rebuilds the solver; other threads' solves never see it half built."""
    A = levels[0][-1].tocsr()
    s = pmgkit.make_solver(A, {"method": "block-jacobi-pcg", "tol": 1e-8})
    n = A.shape[0]

    def work(t):
        tol = [1e-6, 1e-9, 1e-7, 1e-10][t]
        b = _rhs(n, t)
        x, info = s.solve(b, tol=tol)
        return tol, b, x, info

    for tol, b, x, info in _run_together(4, work):
        assert info["status"] == "converged"
        # converged to that thread's own tolerance (relative to ||b - A x0|| = ||b||), with
        # the rounding allowance of the true-residual check
        assert _true_residual(A, b, x) <= 2 * tol
