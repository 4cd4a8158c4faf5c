"""The SciPy user's quick start (docs/quickstart-scipy.md): pmgkit's solvers on SciPy matrices.
Run from the repository root:  PYTHONPATH=build/python /usr/bin/python3 examples/python/quickstart_scipy.py"""
import numpy as np
import scipy.io
import scipy.sparse.linalg as spla

import pmgkit

d = "examples/data/"
read = lambda name: scipy.io.mmread(d + name).tocsr()

# 1. A scalar system (2-D Poisson, 900 unknowns): scalar methods; pmgkit sees no 3x3 blocks in it.
A = read("poisson.mtx")
b = np.ones(A.shape[0])
for config in ({"method": "cg"}, {"method": "jacobi-pcg"}, {"method": "boomeramg-pcg"}, {"method": "cholmod"}):
    x, info = pmgkit.make_solver(A, dict(config, tol=1e-8)).solve(b)
    print(f"poisson   {config['method']:15s} {info['status']:9s} {info['iterations']:4d} iterations, "
          f"residual {info['residual']:.1e}")

# 2. 3-D elasticity (a cubic cantilever, 900 unknowns, interleaved x0 y0 z0 x1 ...): block methods
#    read its 3x3 blocks; the p-multigrid runs on its degree levels (coarsest first).
A = read("elasticity.mtx")
b = scipy.io.mmread(d + "elasticity_b.mtx").ravel()
x_ref = spla.spsolve(A.tocsc(), b)
solvers = {
    "block-jacobi-pcg": pmgkit.make_solver(A, {"method": "block-jacobi-pcg", "tol": 1e-8}),
    "mgpcg": pmgkit.multigrid(levels=[read("elasticity_p1.mtx"), read("elasticity_p2.mtx"), A],
                              prolongations=[read("prolongation_1_2.mtx"), read("prolongation_2_3.mtx")],
                              config={"method": "mgpcg", "tol": 1e-8}),
}
for name, s in solvers.items():
    x, info = s.solve(b)
    error = np.linalg.norm(x - x_ref) / np.linalg.norm(x_ref)
    print(f"cantilever {name:16s} {info['status']:9s} {info['iterations']:4d} iterations, error {error:.0e}")

# 3. pmgkit inside SciPy's own Krylov loop: a fixed linear preconditioner as M=.
iterations = []
M = pmgkit.make_solver(A, {"method": "block-jacobi"}).aspreconditioner()
x, code = spla.cg(A, b, M=M, tol=1e-8, callback=lambda xk: iterations.append(1))
print(f"scipy cg + pmgkit block-jacobi M: code {code}, {len(iterations)} iterations")

# 4. Bad input is a named exception, not a crash.
try:
    pmgkit.make_solver(read("poisson.mtx"), {"method": "block-jacobi-pcg"})
except pmgkit.InputError as e:
    print("InputError:", str(e)[:72], "...")
