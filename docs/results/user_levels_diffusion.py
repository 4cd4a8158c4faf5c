"""The diffusion hierarchy of examples/python/user_levels.py under MGPCG with each smoother and
bound estimate (docs/results/user_levels_defaults_2026-12-02.txt):

    PYTHONPATH=build/python /usr/bin/python3 docs/results/user_levels_diffusion.py
"""
import runpy

import pmgkit

g = runpy.run_path("examples/python/user_levels.py", run_name="levels")  # builds (and solves) its levels
cheb = {"method": "chebyshev", "kind": "opt-fourth", "degree": 3}
for name, cfg in (("gauss-seidel, 2 cycles", {"smoother": "gauss-seidel", "cycles": 2}),
                  ("chebyshev, 15 power steps", {"smoother": {**cheb, "estimate": "power"}}),
                  ("chebyshev, 60 power steps", {"smoother": {**cheb, "estimate": "power", "power_iterations": 60}}),
                  ("chebyshev, 15 Lanczos steps (default)", {"smoother": {**cheb, "estimate": "lanczos"}}),
                  ("chebyshev, 10 Lanczos steps", {"smoother": {**cheb, "estimate": "lanczos", "power_iterations": 10}})):
    for kind, kw in (("levels", dict(levels=g["levels"])), ("finest", dict(finest=g["A"]))):
        try:
            s = pmgkit.multigrid(prolongations=g["prolongations"], config={"method": "mgpcg", "tol": 1e-10, **cfg}, **kw)
            _, info = s.solve(g["b"])
            print(f"{name:<40} {kind:<7} {info['iterations']:>3} iterations")
        except pmgkit.Error as e:
            print(f"{name:<40} {kind:<7} failed: {str(e)[:90]}")
