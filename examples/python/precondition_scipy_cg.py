"""pmgkit as M= in SciPy's CG on an elasticity matrix, against SciPy's own CG and direct solver.

The matrix: a clamped cubic Bernstein-Bezier cantilever (pmgkit's FEM; any SciPy matrix from
another code works the same), 10x2x2 boxes of 24 tetrahedra. SciPy's CG runs without a
preconditioner, with pmgkit's block Jacobi and with one pmgkit multigrid V-cycle on the degree
hierarchy (p = 3, 2, 1; CHOLMOD on p = 1); pmgkit's own MGPCG and SciPy's spsolve close the table.
Every row: iterations, time, true relative residual and error against the direct solution.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/precondition_scipy_cg.py
"""
import os
import sys
import time

# SciPy's CG runs in Python between pmgkit's calls; with libgomp's default wait policy for idle
# threads the block-Jacobi row took 1.45-1.53 s on 2 cores, with "passive" 0.92 s (docs/python.md).
# Set before pmgkit (and libgomp) loads; a value the caller set is kept.
os.environ.setdefault("OMP_WAIT_POLICY", "passive")

import numpy as np
import scipy.sparse.linalg as spla

import pmgkit

mesh = pmgkit.Mesh.box(10, 2, 2, 4.0, 1.0, 1.0)
h = pmgkit.DegreeHierarchy(mesh, 3, pmgkit.Material(5e6, 0.3, 1000.0), clamp=lambda x: x[0] < 1e-9)
levels, prolongations = h.levels(), h.prolongations()
A = levels[-1].tocsr()
b = h.restrict_to_free(h.gravity([0.0, 0.0, -9.81]))
print(f"cubic cantilever: {A.shape[0]} unknowns, {A.nnz} nonzeros")

t0 = time.perf_counter()
x_direct = spla.spsolve(A.tocsc(), b)
t_direct = time.perf_counter() - t0
tol = 1e-8


def report(name, x, iterations, seconds):
    res = np.linalg.norm(b - A @ x) / np.linalg.norm(b)
    err = np.linalg.norm(x - x_direct) / np.linalg.norm(x_direct)
    print(f"{name:<36} {iterations:>6} {seconds:>9.3f} {res:>12.2e} {err:>10.2e}")
    return res


def scipy_cg(M):
    count = [0]
    t0 = time.perf_counter()
    x, info = spla.cg(A, b, M=M, tol=tol, atol=0.0, maxiter=50000,
                      callback=lambda _: count.__setitem__(0, count[0] + 1))
    return x, count[0], time.perf_counter() - t0, info


print(f"{'solver':<36} {'iters':>6} {'time [s]':>9} {'rel. resid.':>12} {'rel. error':>10}")
results = {}
x, it, sec, info = scipy_cg(None)
results["cg"] = (report("scipy cg", x, it, sec), it)
t0 = time.perf_counter()
bj = pmgkit.make_solver(A, {"method": "block-jacobi"})
x, it, sec, info = scipy_cg(bj.aspreconditioner())
results["bj"] = (report("scipy cg + pmgkit block-jacobi", x, it, time.perf_counter() - t0), it)
t0 = time.perf_counter()
mg = pmgkit.multigrid(levels=levels, prolongations=prolongations,
                      config={"method": "pmg", "cycles": 1, "smoother": {"method": "gauss-seidel", "sweeps": 2}})
setup = time.perf_counter() - t0
x, it, sec, info = scipy_cg(mg.aspreconditioner())
results["mg"] = (report("scipy cg + pmgkit V-cycle", x, it, setup + sec), it)
t0 = time.perf_counter()
mgpcg = pmgkit.multigrid(levels=levels, prolongations=prolongations, config={"method": "mgpcg", "tol": tol})
x, info = mgpcg.solve(b)
results["mgpcg"] = (report("pmgkit mgpcg", x, info["iterations"], time.perf_counter() - t0), info["iterations"])
report("scipy spsolve (SuperLU)", x_direct, 1, t_direct)

ok = all(r[0] < 1.01 * tol for r in results.values()) and results["mg"][1] < results["bj"][1] < results["cg"][1]
print("every CG within its tolerance; the V-cycle needs fewer iterations than block Jacobi, "
      "block Jacobi fewer than none:", "yes" if ok else "NO")
sys.exit(0 if ok else 1)
