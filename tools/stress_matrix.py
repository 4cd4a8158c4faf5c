"""Stability stress matrix for pmg simulate: near-incompressible material (point and vertex-patch
smoothers, and the mixed displacement-pressure formulation up to nu = 0.5), time steps from 1e-4 to 0.1 s, large compression, flat and needle elements, a thin
plate with holes, a spinning free body over 10,000 steps; in the full run (not --quick) also the
cubic Homer (models/homer.ele, scripts/get_models.sh and the README's mesh command) at
nu = 0.3, 0.45, 0.49 and 0.499 with both smoothers.

Each case is a scene run by `pmg simulate`; it passes when the run either finishes with finite
results and an energy that never rises above its start (undamped runs: implicit Euler only removes
energy; 1e-4 relative is allowed for the lagged-rotation wobble of a spinning body), or stops
with a clear error (exit 1 or 2 and a message naming what failed). A crash, a hang, a NaN in the
output or an energy rise is a failure. Prints a Markdown table (and writes it to --out .md);
exit code 1 if any case failed.

  /usr/bin/python3 tools/stress_matrix.py --pmg build/tools/pmg [--quick] [--out stress]
"""
import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time

import pmgreport

BAR = {"mesh": {"box": [8, 2, 2], "size": [4, 1, 1]}, "degree": 2,
       "material": {"model": "corotational", "young": 5e6, "poisson": 0.3, "density": 1000},
       "clamp": {"axis": "x"}, "initial": {"state": "deflected", "force": [0, 0, -4000]},
       "time": {"dt": 0.01, "duration": 0.5}, "solver": {"method": "pmg", "tol": 1e-3}}


def case(name, base=BAR, **changes):
    scene = json.loads(json.dumps(base))
    for path, value in changes.items():
        d = scene
        keys = path.split("__")
        for k in keys[:-1]:
            d = d.setdefault(k, {})
        d[keys[-1]] = value
    return name, scene


def cases(quick, only=None):
    out = []
    for nu in (0.3, 0.45, 0.49, 0.499):
        out.append(case("Poisson %g" % nu, material__poisson=nu))
    # Both smoothers by name (the default pmg takes vertex patches from lambda/mu = 99, nu = 0.495 on;
    # mgpcg keeps the point smoother): cycles and time side by side (docs/robustness.md).
    for nu in (0.49, 0.499):
        for method in ("pmg", "mgpcg"):
            for label, key, value in (("point", "smoother.method", "chebyshev"),
                                      ("patch", "smoother.preconditioner.method", "patch")):
                out.append(case("Poisson %g, %s, %s smoother" % (nu, method.upper(), label), material__poisson=nu,
                                solver={"method": method, "tol": 1e-3, key: value}))
    for dt in (1e-4, 1e-3, 1e-2, 1e-1):
        out.append(case("dt = %g s" % dt, time={"dt": dt, "duration": 50 * dt}))
    for eps in (1e-2, 1e-4):
        out.append(case("sliver element (vertices %g off a plane)" % (3 * eps), sliver=eps, degree=3,
                        clamp={"axis": "z"}, initial={"state": "compressed", "strain": 0.1},
                        time={"dt": 0.001, "duration": 0.05}))
    for contrast in (1e3, 1e6):
        out.append(case("Young's contrast %g (stiff core)" % contrast,
                        material__inclusion={"min": [1.5, 0.25, 0.25], "max": [2.5, 0.75, 0.75], "young": 5e6 * contrast}))
    out.append(case("compressed 50% and released", initial={"state": "compressed", "strain": 0.5},
                    time={"dt": 0.005, "duration": 0.5}))
    out.append(case("twisted 180 degrees and released", initial={"state": "twisted", "degrees": 180}))
    out.append(case("flat elements (plate 4 x 1 x 0.01)", mesh={"box": [8, 2, 1], "size": [4, 1, 0.01]},
                    initial={"state": "deflected", "force": [0, 0, -0.002]}))
    out.append(case("needle elements (rod 4 x 0.01 x 0.01)", mesh={"box": [16, 1, 1], "size": [4, 0.01, 0.01]},
                    initial={"state": "deflected", "force": [0, 0, -4e-6]}))
    out.append(case("flat elements, MGPCG", mesh={"box": [8, 2, 1], "size": [4, 1, 0.01]},
                    initial={"state": "deflected", "force": [0, 0, -0.002]}, solver={"method": "mgpcg", "tol": 1e-3}))
    out.append(case("needle elements, MGPCG", mesh={"box": [16, 1, 1], "size": [4, 0.01, 0.01]},
                    initial={"state": "deflected", "force": [0, 0, -4e-6]}, solver={"method": "mgpcg", "tol": 1e-3}))
    # The thin parts from rest under gravity (their deflected start above is refused by CHOLMOD's
    # residual check: the rounding floor of these systems lies above it).
    for shape, mesh in (("plate", {"box": [8, 2, 1], "size": [4, 1, 0.01]}),
                        ("rod", {"box": [16, 1, 1], "size": [4, 0.01, 0.01]})):
        for label, key, value in (("point", "smoother.method", "chebyshev"),
                                  ("patch", "smoother.preconditioner.method", "patch")):
            out.append(case("%s from rest under gravity, MGPCG, %s smoother" % (shape, label), mesh=mesh,
                            initial={"state": "rest"}, loads={"gravity": [0, 0, -9.81]},
                            solver={"method": "mgpcg", "tol": 1e-3, key: value}))
    # A thin plate with holes (4 x 1 x 0.02 m, three round holes of radius 0.25 m, staircase edges
    # from a 40 x 10 x 1 grid of cubes), from rest under gravity: both smoothers, nu = 0.3 and 0.49.
    for nu in (0.3, 0.49):
        for label, key, value in (("point", "smoother.method", "chebyshev"),
                                  ("patch", "smoother.preconditioner.method", "patch")):
            out.append(case("plate with holes, Poisson %g, MGPCG, %s smoother" % (nu, label), holed_plate=True,
                            material__poisson=nu, initial={"state": "rest"}, loads={"gravity": [0, 0, -9.81]},
                            time={"dt": 0.01, "duration": 0.2},
                            solver={"method": "mgpcg", "tol": 1e-3, key: value}))
    # The cubic Homer (97.5k unknowns), clamped at its lowest 5% in z, from rest under gravity, a few
    # steps per case: minutes per case, so only in the full run.
    homer = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "models", "homer.ele")
    if not quick and os.path.exists(homer):
        for nu in (0.3, 0.45, 0.49, 0.499):
            for method in ("pmg", "mgpcg"):
                for label, key, value in (("point", "smoother.method", "chebyshev"),
                                          ("patch", "smoother.preconditioner.method", "patch")):
                    out.append(case("Homer P3, Poisson %g, %s, %s smoother" % (nu, method.upper(), label),
                                    mesh={"file": os.path.abspath(homer)}, degree=3, clamp={"axis": "z", "fraction": 0.05},
                                    material__poisson=nu, initial={"state": "rest"}, loads={"gravity": [0, 0, -9.81]},
                                    time={"dt": 0.01, "duration": 0.03},
                                    solver={"method": method, "tol": 1e-3, key: value}))
    # The mixed displacement-pressure formulation (docs/robustness.md): the same bar up to nu = 0.5,
    # large compression and twist released, the thin plate, and the cubic Homer in the full run.
    mixed = {"formulation": "mixed", "solver": {"method": "mixed-gmres", "tol": 1e-5}}
    for nu in (0.49, 0.499, 0.4999, 0.5):
        out.append(case("mixed, Poisson %g" % nu, material__poisson=nu, **mixed))
    out.append(case("mixed, Poisson 0.499, compressed 50% and released", material__poisson=0.499,
                    initial={"state": "compressed", "strain": 0.5}, time={"dt": 0.005, "duration": 0.5}, **mixed))
    out.append(case("mixed, Poisson 0.499, twisted 180 degrees and released", material__poisson=0.499,
                    initial={"state": "twisted", "degrees": 180}, **mixed))
    out.append(case("mixed, Poisson 0.5, compressed (no finite energy: refused)", material__poisson=0.5,
                    initial={"state": "compressed", "strain": 0.1}, **mixed))
    out.append(case("mixed, Poisson 0.499, plate from rest under gravity", mesh={"box": [8, 2, 1], "size": [4, 1, 0.01]},
                    material__poisson=0.499, initial={"state": "rest"}, loads={"gravity": [0, 0, -9.81]}, **mixed))
    if not quick and os.path.exists(homer):
        for nu in (0.499, 0.4999):
            out.append(case("mixed, Homer P3, Poisson %g" % nu, mesh={"file": os.path.abspath(homer)}, degree=3,
                            clamp={"axis": "z", "fraction": 0.05}, material__poisson=nu, initial={"state": "rest"},
                            loads={"gravity": [0, 0, -9.81]}, time={"dt": 0.01, "duration": 0.03}, **mixed))
    spin = {"mesh": {"box": [4, 1, 1], "size": [2, 0.5, 0.5]}, "degree": 2,
            "material": {"model": "corotational", "young": 5e5, "poisson": 0.3, "density": 1000},
            "clamp": "none", "initial": {"state": "spinning", "omega": [0, 0, 3]},
            "time": {"dt": 0.005, "duration": 5.0 if quick else 50.0}, "solver": {"method": "pmg", "tol": 1e-6}}
    out.append(case("spinning free bar, %d steps" % (1000 if quick else 10000), base=spin))
    out.append(case("solver cannot converge (cg, 2 iterations to 1e-10)",
                    solver={"method": "cg", "tol": 1e-10, "max_iterations": 2}))
    return [c for c in out if not only or only in c[0]]


def write_sliver_mesh(d, eps):
    """A regular corner tetrahedron with a sliver glued on its slanted face: the sliver's four
    vertices lie within 3 eps of one plane while all its edges are long (0.8 to 1.4)."""
    c = 1.0 / 3.0 + eps
    with open(os.path.join(d, "sliver.node"), "w") as f:
        f.write("5 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n5 %.17g %.17g %.17g\n" % (c, c, c))
    with open(os.path.join(d, "sliver.ele"), "w") as f:
        f.write("2 4 0\n1 1 2 3 4\n2 2 3 4 5\n")
    return os.path.join(d, "sliver.ele")


def write_holed_plate(d, nx=40, ny=10, size=(4.0, 1.0, 0.02), holes=((1.0, 0.5), (2.0, 0.5), (3.0, 0.5)),
                      radius=0.25):
    """A plate of nx x ny x 1 cubes, each split into the 6 tetrahedra around its main diagonal
    (Kuhn's subdivision: conforming between neighbours), without the cubes whose centre lies within
    `radius` of a hole's centre. Unused vertices are dropped; every tetrahedron is positively
    oriented."""
    hx, hy, hz = size[0] / nx, size[1] / ny, size[2]
    index, nodes, tets = {}, [], []

    def vertex(i, j, k):
        if (i, j, k) not in index:
            index[(i, j, k)] = len(nodes)
            nodes.append((i * hx, j * hy, k * hz))
        return index[(i, j, k)]

    for i in range(nx):
        for j in range(ny):
            cx, cy = (i + 0.5) * hx, (j + 0.5) * hy
            if any((cx - x) ** 2 + (cy - y) ** 2 < radius ** 2 for x, y in holes):
                continue
            for perm in ((0, 1, 2), (0, 2, 1), (1, 0, 2), (1, 2, 0), (2, 0, 1), (2, 1, 0)):
                corner = [0, 0, 0]
                t = [vertex(i, j, 0)]
                for axis in perm:
                    corner[axis] = 1
                    t.append(vertex(i + corner[0], j + corner[1], corner[2]))
                a, b, c, e = (nodes[v] for v in t)
                u = [b[m] - a[m] for m in range(3)]
                v = [c[m] - a[m] for m in range(3)]
                w = [e[m] - a[m] for m in range(3)]
                det = (u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) +
                       u[2] * (v[0] * w[1] - v[1] * w[0]))
                if det < 0:
                    t[2], t[3] = t[3], t[2]
                tets.append(t)
    with open(os.path.join(d, "holed_plate.node"), "w") as f:
        f.write("%d 3 0 0\n" % len(nodes))
        for n, (x, y, z) in enumerate(nodes):
            f.write("%d %.17g %.17g %.17g\n" % (n + 1, x, y, z))
    with open(os.path.join(d, "holed_plate.ele"), "w") as f:
        f.write("%d 4 0\n" % len(tets))
        for n, t in enumerate(tets):
            f.write("%d %d %d %d %d\n" % (n + 1, t[0] + 1, t[1] + 1, t[2] + 1, t[3] + 1))
    return os.path.join(d, "holed_plate.ele")


def run_case(pmg, name, scene, d):
    if "sliver" in scene:
        eps = scene.pop("sliver")
        scene["mesh"] = {"file": write_sliver_mesh(d, eps)}
    if scene.pop("holed_plate", False):
        scene["mesh"] = {"file": write_holed_plate(d)}
    path = os.path.join(d, "scene.json")
    out = os.path.join(d, "out")
    scene = dict(scene)
    scene["output"] = {"directory": out, "frame_every": 0, "energy": True}
    with open(path, "w") as f:
        json.dump(scene, f)
    t0 = time.time()
    try:
        p, report = pmgreport.run([pmg, "simulate", path, "-q"], timeout=600)
    except subprocess.TimeoutExpired:
        return "FAIL", "hung (no result in 600 s)", time.time() - t0
    wall = time.time() - t0
    if p.returncode not in (0, 1, 2):
        return "FAIL", "crashed (exit %d)" % p.returncode, wall
    if p.returncode != 0:
        if report and "failure" in report:  # a step failed: the report names it
            f = report["failure"]
            return "clear error", ("simulation failed at step %d: %s" % (f["step"], f["message"]))[:150], wall
        message = pmgreport.error_line(p)  # bad input: no report, the tool's error line
        if not message:
            return "FAIL", "exit %d without a message" % p.returncode, wall
        return "clear error", message[:150], wall
    if report is None:
        return "FAIL", "exit 0 without a report", wall
    steps = os.path.join(out, "steps.csv")
    rows = open(steps).read().strip().splitlines()[1:]
    energy = [float(r.split(",")[7]) for r in rows]
    if any(not math.isfinite(float(x)) for r in rows for x in r.split(",")[:8]):
        return "FAIL", "non-finite values in steps.csv", wall
    e0, peak = energy[0], max(energy)
    # A run from rest starts with (close to) zero energy: changes relative to it mean nothing, and
    # the loads' work changes the energy anyway, so it is not judged (only finite values are).
    from_rest = scene.get("initial", {}).get("state") == "rest" or e0 == 0
    rise = 0.0 if from_rest else (peak - e0) / abs(e0)
    st = report["steps"]
    change = "from rest" if from_rest else "%+.1f%%" % (100 * (energy[-1] - e0) / abs(e0))
    detail = "%d steps, %.2f %s per step, energy %s, peak rise %.1e" % (
        st["done"], st["iterations_per_step"], st["iterations_are"], change, rise)
    if rise > 1e-4:
        return "FAIL", "energy rose: " + detail, wall
    return "ok", detail, wall


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--pmg", default="build/tools/pmg")
    ap.add_argument("--quick", action="store_true", help="1,000 instead of 10,000 spinning steps")
    ap.add_argument("--out", default="")
    ap.add_argument("--only", default="", help="run the cases whose name contains this")
    a = ap.parse_args()
    lines = ["| case | outcome | details | wall [s] |", "| --- | --- | --- | ---: |"]
    failed = 0
    for name, scene in cases(a.quick, a.only):
        with tempfile.TemporaryDirectory() as d:
            outcome, detail, wall = run_case(a.pmg, name, scene, d)
        failed += outcome == "FAIL"
        lines.append("| %s | %s | %s | %.1f |" % (name, outcome, detail.replace("|", "/"), wall))
        print(lines[-1], flush=True)
    table = "\n".join(lines) + "\n"
    if a.out:
        with open(a.out + ".md.tmp", "w") as f:
            f.write(table)
        os.replace(a.out + ".md.tmp", a.out + ".md")
    print("\n" + table)
    print("%d case(s) failed" % failed if failed else "all cases passed")
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
