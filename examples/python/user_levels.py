"""A three-level hierarchy built in Python, solved by pmgkit's MGPCG.

A coupled three-component diffusion problem on the unit cube (-div(C grad u) = f, C a full SPD
3x3 coupling, so every pair of neighbouring nodes couples all components as in elasticity),
discretised on nested grids of 5, 9 and 17 points per direction by a 7-point stencil scaled like
a finite-element stiffness (h^(d-2)), with trilinear interpolation between the grids. The matrices
keep the boundary as a FEM code does: identity rows and zeroed columns for u = 0 (pmgkit removes
those nodes itself). Solved with the re-discretised levels, and with the finest matrix alone
(Galerkin products below); checked against SciPy's direct solver.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/user_levels.py
"""
import sys
import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

import pmgkit

C = np.array([[3.0, 1.0, 1.0], [1.0, 3.0, 1.0], [1.0, 1.0, 3.0]])


def level_matrix(m):
    """m points per direction (boundary included), h = 1/(m-1); interleaved x, y, z per node."""
    h = 1.0 / (m - 1)
    d = sp.diags([-np.ones(m - 1), 2 * np.ones(m), -np.ones(m - 1)], [-1, 0, 1])
    I = sp.identity(m)
    L = h * (sp.kron(sp.kron(d, I), I) + sp.kron(sp.kron(I, d), I) + sp.kron(sp.kron(I, I), d))
    i, j, k = np.meshgrid(*[np.arange(m)] * 3, indexing="ij")
    boundary = ((i == 0) | (j == 0) | (k == 0) | (i == m - 1) | (j == m - 1) | (k == m - 1)).ravel()
    keep = sp.diags((~boundary).astype(float))
    # u = 0 on the boundary: identity rows, zeroed columns
    A = (sp.kron(keep @ L @ keep, C) + sp.kron(sp.diags(boundary.astype(float)), sp.identity(3))).tocsr()
    A.eliminate_zeros()
    return A, boundary


def interpolation(mc):
    """Trilinear interpolation from mc to 2 mc - 1 points per direction (per node)."""
    mf = 2 * mc - 1
    rows, cols, vals = [], [], []
    for i in range(mf):
        taps = [(i // 2, 1.0)] if i % 2 == 0 else [(i // 2, 0.5), (i // 2 + 1, 0.5)]
        for c, w in taps:
            rows.append(i)
            cols.append(c)
            vals.append(w)
    P1 = sp.csr_matrix((vals, (rows, cols)), shape=(mf, mc))
    return sp.kron(sp.kron(P1, P1), P1).tocsr()


sizes = [5, 9, 17]
levels, boundaries = zip(*[level_matrix(m) for m in sizes])
prolongations = [interpolation(m) for m in sizes[:-1]]
A = levels[-1]
n = A.shape[0] // 3
b = np.kron(np.where(boundaries[-1], 0.0, 1.0 / (sizes[-1] - 1) ** 3), np.array([1.0, 0.5, -1.0]))
print(f"levels: {[M.shape[0] for M in levels]} unknowns (boundary identity rows included), "
      f"prolongations {[P.shape for P in prolongations]}")

t0 = time.perf_counter()
x_ref = spla.spsolve(A.tocsc(), b)
t_direct = time.perf_counter() - t0
print(f"{'solver':<42} {'iters':>6} {'setup [s]':>10} {'solve [s]':>10} {'rel. resid.':>12} {'rel. error':>10}")
ok = True
for name, kwargs in (("mgpcg, re-discretised levels", dict(levels=levels)),
                     ("mgpcg, finest + Galerkin products", dict(finest=A))):
    t0 = time.perf_counter()
    s = pmgkit.multigrid(prolongations=prolongations, config={"method": "mgpcg", "tol": 1e-10}, **kwargs)
    setup = time.perf_counter() - t0
    x, info = s.solve(b)
    err = np.linalg.norm(x - x_ref) / np.linalg.norm(x_ref)
    res = np.linalg.norm(b - A @ x) / np.linalg.norm(b)
    print(f"{name:<42} {info['iterations']:>6} {setup:>10.3f} {info['solve_seconds']:>10.3f} {res:>12.2e} {err:>10.2e}")
    ok &= res < 1e-10 and err < 1e-8 and info["iterations"] < 20
    print(f"{'':<42} boundary nodes removed per level: {s.removed_nodes}")
print(f"{'scipy spsolve (SuperLU)':<42} {1:>6} {'':>10} {t_direct:>10.3f}")
print("both hierarchies converge in under 20 iterations to the direct solution:", "yes" if ok else "NO")
if __name__ == "__main__":
    sys.exit(0 if ok else 1)
