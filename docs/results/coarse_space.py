"""Two-grid analysis of the degree-2 -> degree-1 coarse space on a thin plate and on the stress
matrix's bar at nu = 0.3 and 0.499 (docs/robustness.md, "Why the targets are out of reach").

For the implicit-Euler system A = K + M / dt^2 of a clamped quadratic Bernstein-Bezier model (dense,
a few thousand unknowns) it computes the condition number kappa(BA) of the symmetric two-grid
preconditioner B with k damped block-Jacobi steps before and after an exact coarse solve,

    E = I - BA = S (I - P (P^T A P)^-1 P^T A) S,   S = (I - D^-1 A / lmax)^k,

kappa(BA) = 1 / (1 - lambda_max(E)), for four coarse spaces P of the same dimension (one vector
per vertex degree of freedom):
  linear       the degree-1 functions (pmgkit's lowest level, Galerkin = re-discretised);
  smoothed     P after 4 damped Jacobi steps, (I - 4/3 D^-1 A / lmax)^4 P (smoothed aggregation's
               prolongation smoother);
  edge sweeps  the edge coefficients relaxed 16 times by block Jacobi on A_EE (a local
               approximation of the energy-minimising extension);
  harmonic     the energy-minimising extension of the vertex values, -A_EE^-1 A_EV (one global
               solve: as expensive as the problem itself).
CG on B needs about sqrt(kappa) iterations per digit.

  PYTHONPATH=build/python /usr/bin/python3 docs/results/coarse_space.py
"""
import sys

import numpy as np
import scipy.linalg as sl

import pmgkit

CASES = (  # name, boxes, size, Poisson's ratio
    ("plate 4 x 1 x 0.01, nu = 0.3", (8, 2, 1), (4.0, 1.0, 0.01), 0.3),
    ("bar 4 x 1 x 1, nu = 0.3", (8, 2, 2), (4.0, 1.0, 1.0), 0.3),
    ("bar 4 x 1 x 1, nu = 0.499", (8, 2, 2), (4.0, 1.0, 1.0), 0.499),
)
DT = 0.01


def system(mesh, degree, material):
    m = pmgkit.ElasticModel(mesh, degree, material)
    m.fix_vertices(lambda x: x[0] < 1e-12)
    return (m.stiffness() + m.mass() / DT**2).toarray()


def block_diagonal(A):
    D = np.zeros_like(A)
    for i in range(0, A.shape[0], 3):
        D[i:i + 3, i:i + 3] = A[i:i + 3, i:i + 3]
    return D


def kappa(A, L, Dinv, lmax, P, steps):
    """kappa(BA) of the symmetric two-grid method, from the symmetric form L^T E L^-T (A = L L^T)."""
    n = A.shape[0]
    C = P @ np.linalg.solve(P.T @ A @ P, P.T)
    J = L.T @ Dinv @ L / lmax                        # L^T D^-1 L / lmax, similar to D^-1 A / lmax
    S = np.linalg.matrix_power(np.eye(n) - J, steps)
    Et = S @ (np.eye(n) - L.T @ C @ L) @ S
    Et = 0.5 * (Et + Et.T)
    top = sl.eigh(Et, eigvals_only=True, subset_by_index=[n - 1, n - 1])[0]
    return 1.0 / (1.0 - top)


def main():
    print("| case | unknowns | coarse space | kappa, 1 Jacobi step | kappa, 4 steps | sqrt (4 steps) |")
    print("|---|---:|---|---:|---:|---:|")
    for name, boxes, size, nu in CASES:
        mesh = pmgkit.Mesh.box(*boxes, *size)
        material = pmgkit.Material(5e6, nu, 1000)
        A = system(mesh, 2, material)
        h = pmgkit.DegreeHierarchy(mesh, 2, material, clamp=lambda x: x[0] < 1e-12)
        P = np.kron(h.prolongations()[0].toarray(), np.eye(3))
        n = A.shape[0]
        D = block_diagonal(A)
        Dinv = np.linalg.inv(D)
        lmax = sl.eigh(A, D, eigvals_only=True, subset_by_index=[n - 1, n - 1])[0]
        L = np.linalg.cholesky(A)
        # vertex rows: a single 1 in P (Bernstein vertex coefficients are the nodal values)
        vertex = (np.count_nonzero(P, axis=1) == 1) & np.isclose(np.abs(P).max(axis=1), 1.0)
        V, E = np.where(vertex)[0], np.where(~vertex)[0]
        spaces = [("linear", P)]
        Ps = P.copy()
        for _ in range(4):
            Ps = Ps - (4.0 / 3.0 / lmax) * Dinv @ (A @ Ps)
        spaces.append(("smoothed (4 Jacobi steps)", Ps))
        Pe = P.copy()
        DE = block_diagonal(A[np.ix_(E, E)])
        DEinv = np.linalg.inv(DE)
        lE = sl.eigh(A[np.ix_(E, E)], DE, eigvals_only=True, subset_by_index=[len(E) - 1, len(E) - 1])[0]
        for _ in range(16):
            Pe[E] -= DEinv @ (A[E] @ Pe) / lE
        spaces.append(("edge sweeps (16)", Pe))
        Ph = P.copy()
        Ph[E] = -np.linalg.solve(A[np.ix_(E, E)], A[np.ix_(E, V)] @ P[V])
        spaces.append(("harmonic (global solve)", Ph))
        for label, Q in spaces:
            k1, k4 = kappa(A, L, Dinv, lmax, Q, 1), kappa(A, L, Dinv, lmax, Q, 4)
            print("| %s | %d | %s | %.3g | %.3g | %.1f |" % (name, n, label, k1, k4, np.sqrt(k4)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
