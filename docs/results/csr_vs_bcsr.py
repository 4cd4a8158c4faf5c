"""cg + block-Jacobi on the scalar CSR a user passes (read as 3x3 blocks, pmg::BlockInput) against a BCSR: solve times alternating, the first round a warm-up, medians. Run: OMP_NUM_THREADS=2 PYTHONPATH=build/python /usr/bin/python3 docs/results/csr_vs_bcsr.py"""
import statistics, sys, time
import numpy as np, pmgkit
mesh = pmgkit.Mesh.box(12, 4, 4, 3.0, 1.0, 1.0)
h = pmgkit.DegreeHierarchy(mesh, 3, pmgkit.Material(5e6, 0.3, 1000.0), clamp=lambda x: x[0] < 1e-9)
A = h.levels()[-1].tocsr()
b = h.restrict_to_free(h.gravity([0.0, 0.0, -9.81]))
print(f"{A.shape[0]} unknowns, {A.nnz} nonzeros")
times = {"csr": [], "bcsr": []}
its = {}
for rep in range(4):
    for fmt in ("csr", "bcsr"):
        s = pmgkit.make_solver(A, {"method": "cg", "preconditioner": {"method": "block-jacobi"}, "tol": 1e-8}, format=fmt)
        t0 = time.perf_counter(); x, info = s.solve(b); t = time.perf_counter() - t0
        if rep > 0: times[fmt].append(t)
        its[fmt] = info["iterations"]
for fmt in times:
    print(f"{fmt:5s} iterations {its[fmt]}  solve median {statistics.median(times[fmt]):.3f} s  ({', '.join('%.3f' % t for t in times[fmt])})")
print("ratio csr/bcsr %.2f" % (statistics.median(times['csr']) / statistics.median(times['bcsr'])))
