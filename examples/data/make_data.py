"""Writes the small systems that the README, docs/ and examples/ run on (committed; re-run only
when the FEM changes):

    PYTHONPATH=build/python /usr/bin/python3 examples/data/make_data.py

- poisson.mtx, poisson_b.mtx: the 5-point Laplacian on a 30 x 30 grid of interior points (900
  unknowns: a scalar system whose size happens to be a multiple of 3), right-hand side all ones.
- elasticity.mtx, elasticity_b.mtx: a cubic Bernstein-Bezier cantilever (pmgkit's FEM; 2 x 1 x 1
  boxes of 24 tetrahedra, 2 m x 1 m x 1 m, E = 5 MPa, nu = 0.3, clamped at x = 0, gravity):
  interleaved unknowns (x0 y0 z0 x1 ...), symmetric positive definite.
- elasticity_p1.mtx, elasticity_p2.mtx: the same cantilever at degrees 1 and 2 (Galerkin-
  consistent with the prolongations), and prolongation_1_2.mtx, prolongation_2_3.mtx: degree
  elevation from degree 1 to 2 and 2 to 3, so that [p1, p2, elasticity] with those two
  prolongations is a three-level p-multigrid hierarchy (coarsest first).
"""
import os

import numpy as np
import scipy.io
import scipy.sparse as sp

import pmgkit

here = os.path.dirname(os.path.abspath(__file__))


def write(name, matrix, comment, symmetry="general"):
    path = os.path.join(here, name)
    scipy.io.mmwrite(path, matrix, comment=comment, symmetry=symmetry, precision=17)
    print("wrote", name, "%dx%d" % matrix.shape, getattr(matrix, "nnz", ""))


m = 30
T = sp.diags([-np.ones(m - 1), 2 * np.ones(m), -np.ones(m - 1)], [-1, 0, 1])
poisson = (sp.kron(sp.identity(m), T) + sp.kron(T, sp.identity(m))).tocsr()
write("poisson.mtx", poisson, "5-point Laplacian, 30 x 30 interior grid points (examples/data/make_data.py)", "symmetric")
write("poisson_b.mtx", np.ones((poisson.shape[0], 1)), "all ones")

mesh = pmgkit.Mesh.box(2, 1, 1, 2.0, 1.0, 1.0)
h = pmgkit.DegreeHierarchy(mesh, 3, pmgkit.Material(5e6, 0.3, 1000.0), clamp=lambda x: x[0] < 1e-9)
levels, prolongations = h.levels(), h.prolongations()
b = h.restrict_to_free(h.gravity([0.0, 0.0, -9.81]))
what = "cubic BB cantilever 2x1x1 boxes, E=5e6, nu=0.3, clamped at x=0 (examples/data/make_data.py)"
write("elasticity.mtx", levels[2].tocsr(), what, "symmetric")
write("elasticity_b.mtx", b.reshape(-1, 1), "gravity load of elasticity.mtx")
write("elasticity_p1.mtx", levels[0].tocsr(), what.replace("cubic", "linear"), "symmetric")
write("elasticity_p2.mtx", levels[1].tocsr(), what.replace("cubic", "quadratic"), "symmetric")
write("prolongation_1_2.mtx", prolongations[0].tocsr(), "degree elevation 1 -> 2 of the cantilever")
write("prolongation_2_3.mtx", prolongations[1].tocsr(), "degree elevation 2 -> 3 of the cantilever")
