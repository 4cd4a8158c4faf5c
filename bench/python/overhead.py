"""What a solve costs through Python against the same solve through `pmg compare`.

Exports the levels of a cubic BB cantilever (default 12x5x5 boxes of 24 tets, about 110k unknowns)
with `pmg compare --export-levels`, then alternates, --repeat times each: `pmg compare --levels
... --solvers mgpcg` (its set-up and solve columns, from --json), and pmgkit.multigrid(...) on the
same matrices read by SciPy followed by .solve(b), timed from Python around the calls (so the
conversion of the SciPy arrays, the right-hand side's copy and the result's wrapping are
included). Prints the medians and their ratios; the solutions are compared too.

    /usr/bin/python3 bench/python/overhead.py [--build build] [--box 12 5 5] [--repeat 5]

Run on a quiet machine: both sides are memory-bound OpenMP code.
"""
import argparse
import json
import os
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np
import scipy.io

ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
ap.add_argument("--build", default="build")
ap.add_argument("--box", type=int, nargs=3, default=[12, 5, 5])
ap.add_argument("--method", default="mgpcg")
ap.add_argument("--tol", type=float, default=1e-8)
ap.add_argument("--repeat", type=int, default=5)
a = ap.parse_args()
build = pathlib.Path(a.build).resolve()
sys.path.insert(0, str(build / "python"))
import pmgkit  # noqa: E402

pmg = build / "tools" / "pmg"
work = pathlib.Path(tempfile.mkdtemp(prefix="pmgkit-overhead-"))
size = [round(0.2 * n, 6) for n in a.box]
subprocess.run([str(pmg), "compare", "--box", *map(str, a.box), "--size", *map(str, size), "--degree", "3",
                "--solvers", "block-jacobi", "--no-reference", "--export-levels", str(work / "levels")],
               check=True, capture_output=True)
L = sorted((work / "levels").glob("A*.mtx"))
P = sorted((work / "levels").glob("P*.mtx"))
levels = [scipy.io.mmread(f).tocsr() for f in L]
prolongations = [scipy.io.mmread(f).tocsr() for f in P]
b = scipy.io.mmread(work / "levels" / "b.mtx").ravel()
n = levels[-1].shape[0]
print(f"cubic cantilever {'x'.join(map(str, a.box))} boxes: {n} unknowns, {levels[-1].nnz} nonzeros, "
      f"{len(levels)} levels; {a.method} to {a.tol:g}, {os.environ.get('OMP_NUM_THREADS', 'all')} threads")

cli_setup, cli_solve, py_setup, py_solve = [], [], [], []
x_cli = x_py = None
for r in range(a.repeat + 1):  # the first round warms up and is not counted
    out = work / "report.json"
    subprocess.run([str(pmg), "compare", "--levels", ",".join(map(str, L)), "--prolongations", ",".join(map(str, P)),
                    "--rhs", str(work / "levels" / "b.mtx"), "--solvers", a.method, "--tol", str(a.tol),
                    "--json", str(out), "--solution-out", str(work / "x.mtx")], check=True, capture_output=True)
    rep = json.loads(out.read_text())
    row = rep["solvers"][0]
    t0 = time.perf_counter()
    s = pmgkit.multigrid(levels=levels, prolongations=prolongations, config={"method": a.method, "tol": a.tol})
    t1 = time.perf_counter()
    x_py, info = s.solve(b)
    t2 = time.perf_counter()
    del s
    if r == 0:
        x_cli = scipy.io.mmread(work / "x.mtx").ravel()
        iterations = (row["iterations"], info["iterations"])
        continue
    cli_setup.append(row["setup_s"] + rep["user_levels_s"])
    cli_solve.append(row["solve_s"])
    py_setup.append(t1 - t0)
    py_solve.append(t2 - t1)

med = statistics.median
print(f"iterations: pmg compare {iterations[0]}, Python {iterations[1]}; solutions differ by "
      f"{np.linalg.norm(x_py - x_cli) / np.linalg.norm(x_cli):.1e} (relative)")
print(f"{'':<28} {'pmg compare':>12} {'Python':>10} {'ratio':>8}")
print(f"{'solve [s], median of ' + str(a.repeat):<28} {med(cli_solve):>12.4f} {med(py_solve):>10.4f} {med(py_solve) / med(cli_solve):>8.3f}")
print(f"{'levels + set-up [s], median':<28} {med(cli_setup):>12.4f} {med(py_setup):>10.4f} {med(py_setup) / med(cli_setup):>8.3f}")
tot_cli = [a + b for a, b in zip(cli_setup, cli_solve)]
tot_py = [a + b for a, b in zip(py_setup, py_solve)]
print(f"{'total [s], median':<28} {med(tot_cli):>12.4f} {med(tot_py):>10.4f} {med(tot_py) / med(tot_cli):>8.3f}")
print("(levels: turning the CSR matrices into the cycle's BCSR levels, mg::UserLevels, in both; "
      "pmg compare's file reading is not counted, nor SciPy's.)")
