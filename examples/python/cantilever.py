"""The BB elasticity FEM from Python: the seed's cantilever (Table 2.6) for degrees 1-3.

A 1.0 x 0.2 x 0.2 m bar, E = 500 kPa, nu = 0.3, every BB node of the face x = 0 fixed, 10 N down
as a uniform traction on the end face; the end-face centre's deflection against the converged 3-D
value 0.05087 m (Table 2.6 in docs/performance.md: cubic elements on 20x4x4 boxes give 0.050851 m).

    PYTHONPATH=build/python /usr/bin/python3 examples/python/cantilever.py
"""
import sys
import time

import numpy as np

import pmgkit

CONVERGED = 0.05087  # m, downwards
mesh_sizes = [(5, 1, 1), (10, 2, 2)]
print(f"{'mesh':>8} {'degree':>6} {'unknowns':>9} {'tip z [m]':>11} {'error':>8} {'time [s]':>9}")
errors = {}
for boxes in mesh_sizes:
    mesh = pmgkit.Mesh.box(*boxes, 1.0, 0.2, 0.2)
    for degree in (1, 2, 3):
        t0 = time.perf_counter()
        model = pmgkit.ElasticModel(mesh, degree, pmgkit.Material(young=500e3, poisson=0.3, density=1000.0))
        X = model.node_positions()
        model.fix_nodes(np.flatnonzero(X[:, 0] < 1e-12))
        f, area = model.traction(lambda x: x[0] > 1.0 - 1e-12, [0.0, 0.0, -10.0 / 0.04])
        u, _ = model.solve_static(f)
        tip = model.displacement_at(u, [[1.0, 0.1, 0.1]])[0]
        seconds = time.perf_counter() - t0
        err = (-tip[2] - CONVERGED) / CONVERGED
        errors[(boxes, degree)] = err
        print(f"{'x'.join(map(str, boxes)):>8} {degree:>6} {model.num_free_dofs:>9} {tip[2]:>11.5f} "
              f"{100 * err:>7.2f}% {seconds:>9.2f}")

# The checks of Table 2.6: cubic within 0.5% on 5x1x1, and every refinement closer.
ok = abs(errors[((5, 1, 1), 3)]) < 0.005 and all(
    abs(errors[((10, 2, 2), p)]) < abs(errors[((5, 1, 1), p)]) for p in (1, 2, 3))
print("cubic on 5x1x1 within 0.5% of the converged deflection, refinement closer for every degree:",
      "yes" if ok else "NO")
sys.exit(0 if ok else 1)
