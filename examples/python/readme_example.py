import numpy as np, scipy.io, scipy.sparse.linalg as spla, pmgkit

d = "examples/data/"                       # run from the repository root
A = scipy.io.mmread(d + "elasticity.mtx").tocsr()    # a cubic cantilever, 900 unknowns
b = scipy.io.mmread(d + "elasticity_b.mtx").ravel()

s = pmgkit.make_solver(A, {"method": "cg", "tol": 1e-8,
                           "preconditioner": {"method": "block-jacobi"}})
x, info = s.solve(b)            # info: status, iterations, residual (true ‖b−Ax‖/‖b‖), history, ...
print("block-Jacobi PCG:", info["status"], info["iterations"], "iterations")
s.update(2 * A)                 # new values, same pattern: numeric set-up only

M = pmgkit.make_solver(A, {"method": "block-jacobi"}).aspreconditioner()
x, _ = spla.cg(A, b, M=M)       # a fixed preconditioner as SciPy's M=

read = lambda *names: [scipy.io.mmread(d + n).tocsr() for n in names]
mg = pmgkit.multigrid(levels=read("elasticity_p1.mtx", "elasticity_p2.mtx", "elasticity.mtx"),
                      prolongations=read("prolongation_1_2.mtx", "prolongation_2_3.mtx"),
                      config={"method": "mgpcg"})                   # coarsest first
x, info = mg.solve(b)
error = np.linalg.norm(x - spla.spsolve(A.tocsc(), b)) / np.linalg.norm(x)
print("MGPCG:", info["status"], info["iterations"], "iterations, error %.0e" % error)
