"""Property-based tests of the solver contract (Debian's python3-hypothesis), for every method of
the factory but the GPU ones, over random SPD systems, scalings from 1e-300 to 1e300, starting
guesses (zero, random, the exact solution), per-call tolerances, input dtypes, repeated calls and
update()s:
  - a reported success means the requested true residual was reached (iterative methods:
    ||b - A x|| <= 2 tol ||b|| (||b - A x0|| where b = 0), their true-residual check's allowance; direct methods:
    ||b - A x|| <= tol ||b|| or a rounding-level answer; a preconditioner used as a solver asks for nothing);
  - a failure is a pmgkit exception with a message, never a crash or a NaN returned as success;
  - a call never changes what the next one does (the same solve after a failed one, or after an
    update() with the same values, gives the same answer).
The examples are derandomized (the same on every run). PMG_PROPERTY_EXAMPLES sets the number per
method (default 3, the README test command; 40 under the CTest label "properties")."""
import os

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import pmgkit

EXAMPLES = int(os.environ.get("PMG_PROPERTY_EXAMPLES", "3"))
SETTINGS = settings(max_examples=EXAMPLES, deadline=None, derandomize=True, database=None,
                    suppress_health_check=list(HealthCheck))
METHODS = [m for m in pmgkit.methods() if m["component"] != "gpu"]
KEYS = {m["name"]: {k["key"] for k in m["keys"]} for m in METHODS}


def kind(method):
    if "max_iterations" in KEYS[method]:
        return "iterative"
    if "refinement_steps" in KEYS[method]:
        return "direct"
    return "one-shot"


def random_spd(rng, nb, scale):
    """Symmetric, strictly diagonally dominant (so SPD) with 3x3 blocks on a random pattern."""
    n = 3 * nb
    rows, cols, vals = [], [], []
    offsum = np.zeros(n)

    def block(I, J):
        v = rng.uniform(-1, 1, (3, 3))
        for a in range(3):
            for c in range(3):
                rows.extend([3 * I + a, 3 * J + c])
                cols.extend([3 * J + c, 3 * I + a])
                vals.extend([v[a, c], v[a, c]])
                offsum[3 * I + a] += abs(v[a, c])
                offsum[3 * J + c] += abs(v[a, c])

    for I in range(nb):
        if I + 1 < nb:
            block(I, I + 1)
        for J in rng.integers(0, nb, 2):
            if abs(int(J) - I) > 1:
                block(I, int(J))
    A = sp.csr_matrix((vals, (rows, cols)), shape=(n, n))
    A = A + sp.diags(offsum + rng.uniform(0.05, 2.0, n))
    return (A * scale).tocsr()


def safe_norm(v):
    m = np.max(np.abs(v)) if v.size else 0.0
    return 0.0 if m == 0 or not np.isfinite(m) else m * np.linalg.norm(v / m)


def solve_checked(s, method, tol, A, b, x0):
    """Solves; checks a success against the request. Returns x, or None for a failure."""
    try:
        x, info = s.solve(b, x0=x0)
    except pmgkit.SolveError as e:
        assert str(e)
        return None
    assert info["status"] in ("converged", "completed"), info
    assert np.all(np.isfinite(x))
    bf = np.asarray(b, dtype=np.float64)
    rn = safe_norm(bf - A @ x)
    # The reference of tol: ||b|| (||r0|| where b = 0), as in SciPy and PETSc.
    ref = safe_norm(bf)
    if ref == 0:
        ref = safe_norm(bf - A @ (np.zeros_like(bf) if x0 is None else np.asarray(x0, dtype=np.float64)))
    if kind(method) == "iterative":
        assert rn <= 2 * tol * ref * (1 + 1e-12)
    elif kind(method) == "direct":
        # Within tol, or an answer at rounding level: normwise backward error <= 1e-12 and growth
        # ||A|| ||x|| / ||b|| <= 4.5e12 (infinity norms, as judge_direct_answer).
        if not rn <= tol * ref * (1 + 1e-12):
            a = abs(A).sum(axis=1).max()
            r = bf - A @ x
            eta = np.abs(r).max() / (a * np.abs(x).max() + np.abs(bf).max())
            assert eta <= 1e-12 and a * np.abs(x).max() / np.abs(bf).max() <= 4.5e12
    else:
        assert info["status"] == "completed"
    return x


def check_contract(s, method, tol, A, b, x0):
    x1 = solve_checked(s, method, tol, A, b, x0)
    try:  # another right-hand side, failed or not, changes nothing for the next call
        s.solve(np.asarray(b, dtype=np.float64) * 1e-300, x0=np.full(A.shape[0], 1e300))
    except pmgkit.Error as e:
        assert str(e)
    x2 = solve_checked(s, method, tol, A, b, x0)
    assert (x1 is None) == (x2 is None)
    if x1 is not None:
        assert safe_norm(x2 - x1) <= 1e-12 * safe_norm(x1)
    return x1


def guess_for(kind_of_guess, rng, x_star):
    if kind_of_guess == "zero":
        return None
    if kind_of_guess == "random":
        return rng.standard_normal(x_star.size)
    return x_star


@pytest.mark.parametrize("method", [m["name"] for m in METHODS if not m["uses_levels"]])
@SETTINGS
@given(seed=st.integers(0, 2**31 - 1), exponent=st.integers(-300, 300),
       guess=st.sampled_from(["zero", "random", "exact"]), tol=st.sampled_from([1e-4, 1e-8, 1e-10]),
       b_dtype=st.sampled_from(["float64", "float32", "int64"]),
       a_dtype=st.sampled_from(["float64", "float32"]))
@np.errstate(over="ignore", under="ignore", invalid="ignore")
def test_contract_on_random_systems(method, seed, exponent, guess, tol, b_dtype, a_dtype):
    rng = np.random.default_rng(seed)
    A = random_spd(rng, int(rng.integers(4, 30)), 10.0 ** exponent)
    if a_dtype == "float32":
        A = A.astype(np.float32)
        if not np.all(np.isfinite(A.data)):
            return  # the scale is beyond float32: no system to ask about
    A64 = A.astype(np.float64)
    cfg = {"method": method}
    if kind(method) != "one-shot":
        cfg["tol"] = tol
    try:
        s = pmgkit.make_solver(A, cfg)
    except pmgkit.Error as e:  # a set-up may refuse a system, by an exception that says why
        assert str(e)
        return
    x_star = rng.standard_normal(A.shape[0])
    b = (A64 @ x_star).astype(b_dtype) if b_dtype != "int64" else np.rint(A64 @ x_star * 1e3).astype(np.int64)
    if not np.all(np.isfinite(np.asarray(b, dtype=np.float64))) or not np.any(b):
        return
    x0 = guess_for(guess, rng, x_star)
    x1 = check_contract(s, method, tol, A64, b, x0)
    try:
        s.update(A)  # the same values: the same answers
    except pmgkit.Error as e:
        assert str(e)
        return
    x3 = solve_checked(s, method, tol, A64, b, x0)
    assert (x1 is None) == (x3 is None)
    if x1 is not None:
        assert safe_norm(x3 - x1) <= 1e-10 * safe_norm(x1)


@pytest.mark.parametrize("method", [m["name"] for m in METHODS if m["uses_levels"]])
@SETTINGS
@given(exponent=st.integers(-300, 300), guess=st.sampled_from(["zero", "random", "exact"]),
       tol=st.sampled_from([1e-4, 1e-8, 1e-10]), seed=st.integers(0, 2**31 - 1))
@np.errstate(over="ignore", under="ignore", invalid="ignore")
def test_contract_on_scaled_multigrid_levels(levels, method, exponent, guess, tol, seed):
    rng = np.random.default_rng(seed)
    mats = [(M * 10.0 ** exponent).tocsr() for M in levels[0]]
    if not all(np.all(np.isfinite(M.data)) for M in mats):
        return
    A = mats[-1]
    try:
        s = pmgkit.multigrid(levels=mats, prolongations=levels[1], config={"method": method, "tol": tol})
    except pmgkit.Error as e:
        assert str(e)
        return
    x_star = rng.standard_normal(A.shape[0])
    b = A @ x_star
    if not np.all(np.isfinite(b)):
        return
    check_contract(s, method, tol, A, b, guess_for(guess, rng, x_star))
