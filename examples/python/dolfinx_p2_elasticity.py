"""Optional: P2 elasticity assembled by FEniCSx (dolfinx), solved by pmgkit's multigrid.

dolfinx assembles linear elasticity on a clamped box with P1 and P2 vector Lagrange elements
(Dirichlet rows kept as identity rows, columns zeroed, as dolfinx does) and gives its own
interpolation matrix P1 -> P2 (per dof, block size 3) as the prolongation. pmgkit's MGPCG solves
the P2 system on those two levels; the solution is checked against dolfinx's own direct solve
(PETSc LU). Skipped, with a message and exit code 77, when dolfinx (Debian's python3-dolfinx)
is not installed.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/dolfinx_p2_elasticity.py
"""
import sys
import time

try:
    import dolfinx
    import dolfinx.fem
    import dolfinx.fem.petsc
    import ufl
    from mpi4py import MPI
    from petsc4py import PETSc
except ImportError as e:
    print(f"skipped: FEniCSx is not installed ({e}); apt-get install python3-dolfinx-real")
    sys.exit(77)

import numpy as np
import scipy.sparse as sp

import pmgkit

E, nu, rho, g = 1e5, 0.3, 1e3, 9.81
mu, lam = E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))
mesh = dolfinx.mesh.create_box(MPI.COMM_WORLD, [np.array([0.0, 0.0, 0.0]), np.array([4.0, 1.0, 1.0])],
                               [16, 4, 4], dolfinx.mesh.CellType.tetrahedron)


def system(degree):
    V = dolfinx.fem.VectorFunctionSpace(mesh, ("Lagrange", degree))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    eps = lambda w: ufl.sym(ufl.grad(w))  # noqa: E731
    a = dolfinx.fem.form((2 * mu * ufl.inner(eps(u), eps(v)) + lam * ufl.div(u) * ufl.div(v)) * ufl.dx)
    f = dolfinx.fem.Constant(mesh, np.array([0.0, 0.0, -rho * g]))
    L = dolfinx.fem.form(ufl.inner(f, v) * ufl.dx)
    clamped = dolfinx.mesh.locate_entities_boundary(mesh, 2, lambda x: np.isclose(x[0], 0.0))
    zero = np.zeros(3, dtype=np.float64)
    bc = dolfinx.fem.dirichletbc(zero, dolfinx.fem.locate_dofs_topological(V, 2, clamped), V)
    A = dolfinx.fem.petsc.assemble_matrix(a, bcs=[bc])
    A.assemble()
    b = dolfinx.fem.petsc.assemble_vector(L)
    dolfinx.fem.petsc.apply_lifting(b, [a], [[bc]])
    b.ghostUpdate()
    dolfinx.fem.petsc.set_bc(b, [bc])
    return V, a, L, bc, A, b


def to_scipy(M):
    indptr, indices, data = M.convert("aij").getValuesCSR()
    return sp.csr_matrix((data, indices, indptr), shape=M.getSize())


t0 = time.perf_counter()
V1, _, _, _, A1, _ = system(1)
V2, a2, L2, bc2, A2, b2 = system(2)
P = dolfinx.cpp.fem.petsc.interpolation_matrix(V1._cpp_object, V2._cpp_object)
P.assemble()
levels, prolongation, b = [to_scipy(A1), to_scipy(A2)], to_scipy(P), b2.array.copy()
print(f"dolfinx {dolfinx.__version__}: P1 {levels[0].shape[0]} and P2 {levels[1].shape[0]} unknowns, "
      f"interpolation {prolongation.shape} (per dof); assembled in {time.perf_counter() - t0:.2f} s")

t0 = time.perf_counter()
ksp = PETSc.KSP().create(MPI.COMM_WORLD)
ksp.setOperators(A2)
ksp.setType("preonly")
ksp.getPC().setType("lu")
xv = b2.duplicate()
ksp.solve(b2, xv)
x_ref = xv.array.copy()
t_lu = time.perf_counter() - t0

t0 = time.perf_counter()
mg = pmgkit.multigrid(levels=levels, prolongations=[prolongation], config={"method": "mgpcg", "tol": 1e-10})
x, info = mg.solve(b)
t_mg = time.perf_counter() - t0
err = np.linalg.norm(x - x_ref) / np.linalg.norm(x_ref)
print(f"pmgkit mgpcg on dolfinx's levels: {info['iterations']} iterations, residual {info['residual']:.1e}, "
      f"{t_mg:.2f} s (set-up included); clamped nodes removed per level {mg.removed_nodes}")
print(f"dolfinx's own direct solve (PETSc LU): {t_lu:.2f} s; relative difference {err:.1e}")
ok = info["residual"] < 1e-10 and err < 1e-7
print("the multigrid solution matches dolfinx's direct solve:", "yes" if ok else "NO")
sys.exit(0 if ok else 1)
