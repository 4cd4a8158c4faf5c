"""Run time against error (a work-precision diagram) for the released cantilever.

For degrees 1-3, several refinements of the 4 x 1 x 1 m bar and several per-step PMG tolerances,
runs `pmg simulate` for a short time and records the probe's (centre of the free end) vertical
displacement at the end against the run's wall time. The error is measured against a reference
run: degree 3 on a finer mesh than any in the sweep, solved to 1e-10 per step by PMG (--reference-solver
cholmod: by CHOLMOD, the default in model mode, where stationary PMG needs hundreds of cycles per
step for 1e-10 on a 200k-unknown cubic Bunny), the same time step
(so the time-discretisation error, common to all runs, cancels and the error is that of space and
solver). Writes <out>.csv, <out>.md and <out>.png (matplotlib):

  /usr/bin/python3 tools/work_precision.py --pmg build/tools/pmg --out wp

Model mode (--mesh): a real model compressed along --clamp-axis by 20% and released, clamped at the
minimum of that axis; the meshes of the sweep are the model's mesh refined uniformly
(--refinements, each splits every tetrahedron into 8 on the same geometry, so the clamped region
and the surface are the same for all), the reference is degree 3 on a finer refinement; the
quantity is the probe point's displacement along the clamp axis.
"""
import argparse
import json
import os
import tempfile
import time

import pmgreport


def scene(p, mesh, tol, duration, dt, model=None, method=None):
    """mesh: a number of boxes across the bar, or (model mode) a number of uniform refinements."""
    sc = {"mesh": {"box": [4 * mesh, mesh, mesh], "size": [4, 1, 1]}, "degree": p,
          "material": {"model": "corotational", "young": 5e6, "poisson": 0.3, "density": 1000},
          "clamp": {"axis": "x"}, "initial": {"state": "deflected", "force": [0, 0, -4000]},
          "time": {"dt": dt, "duration": duration},
          "solver": {"method": method or ("pmg" if p > 1 else "cholmod")},
          "output": {"energy": False}}
    if sc["solver"]["method"] != "cholmod":  # a direct solve has no tolerance (the factory refuses one)
        sc["solver"].update({"tol": tol, "max_iterations": 5000})
    if model:
        sc["mesh"] = {"file": os.path.abspath(model["mesh"]), "refine": mesh}
        sc["material"]["young"] = 1e6
        sc["clamp"] = {"axis": model["axis"], "fraction": model["fraction"]}
        sc["initial"] = {"state": "compressed", "strain": 0.2}
        sc["output"]["probe"] = model["probe"]
    return sc


def run(pmg, sc, axis=2):
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "s.json")
        with open(path, "w") as f:
            json.dump(sc, f)
        t0 = time.time()
        p, report = pmgreport.run([pmg, "simulate", path, "-q"])
        wall = time.time() - t0
    if p.returncode != 0 or report is None:
        raise SystemExit("work_precision: pmg simulate failed:\n" + p.stdout + p.stderr)
    return report["probe"]["displacement_m"][axis], report["mesh"]["unknowns"], wall


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--pmg", default="build/tools/pmg")
    ap.add_argument("--boxes", default="1,2,3", help="boxes across the bar (4x as many along it)")
    ap.add_argument("--reference-boxes", type=int, default=4)
    ap.add_argument("--tols", default="1e-2,1e-3,1e-5")
    ap.add_argument("--duration", type=float, default=0.3)
    ap.add_argument("--dt", type=float, default=0.01)
    ap.add_argument("--out", default="work_precision")
    ap.add_argument("--mesh", default="", help="model mode: the model's mesh file")
    ap.add_argument("--refinements", default="0,1", help="model mode: uniform refinements of the sweep")
    ap.add_argument("--reference-refine", type=int, default=2, help="model mode: the reference's refinements")
    ap.add_argument("--clamp-axis", default="z", choices=("x", "y", "z"), help="model mode: compression and clamp axis")
    ap.add_argument("--clamp-fraction", type=float, default=0.1, help="model mode: fraction clamped at the axis' minimum")
    ap.add_argument("--probe", default="", help="model mode: rest point x,y,z inside every mesh")
    ap.add_argument("--reference-solver", choices=("pmg", "mgpcg", "cholmod"), default=None,
                    help="the reference's solver (default: pmg to 1e-10 for the bar, cholmod for a model)")
    a = ap.parse_args()
    model = None
    meshes = [int(x) for x in a.boxes.split(",")]
    ref_mesh = a.reference_boxes
    axis = 2
    if a.mesh:
        if not a.probe:
            raise SystemExit("work_precision: --mesh needs --probe")
        model = {"mesh": a.mesh, "axis": a.clamp_axis, "fraction": a.clamp_fraction,
                 "probe": [float(x) for x in a.probe.split(",")]}
        meshes, ref_mesh, axis = [int(r) for r in a.refinements.split(",")], a.reference_refine, "xyz".index(a.clamp_axis)
    ref_solver = a.reference_solver or ("cholmod" if model else "pmg")
    ref, ref_n, ref_wall = run(a.pmg, scene(3, ref_mesh, 1e-10, a.duration, a.dt, model, ref_solver), axis)
    comp = "xyz"[axis]
    print("reference: degree 3, %d unknowns, probe %s = %.8f m (%.1f s)" % (ref_n, comp, ref, ref_wall), flush=True)
    rows = []
    for p in (1, 2, 3):
        for b in meshes:
            for tol in [float(t) for t in a.tols.split(",")] if p > 1 else [0.0]:
                z, n, wall = run(a.pmg, scene(p, b, tol if p > 1 else 1e-3, a.duration, a.dt, model), axis)
                err = abs(z - ref) / abs(ref)
                rows.append((p, b, n, tol, z, err, wall))
                print("p=%d mesh=%s unknowns=%d tol=%g: u=%.8f error %.2e, %.2f s" % (p, b, n, tol, z, err, wall), flush=True)
    csv = "degree,mesh,unknowns,tol,probe_z,rel_error,wall_s\n" + "".join(
        "%d,%s,%d,%g,%.10g,%.4g,%.4g\n" % r for r in rows)
    how = {"cholmod": "CHOLMOD (direct)", "pmg": "PMG to 1e-10", "mgpcg": "MGPCG to 1e-10"}[ref_solver]
    md = ["reference: degree 3, %d unknowns, %s per step, probe %s = %.6f m at t = %g s\n" % (ref_n, how, comp, ref, a.duration),
          "| degree | mesh | unknowns | tolerance per step | probe %s [m] | error | run time [s] |" % comp,
          "| --- | --- | ---: | ---: | ---: | ---: | ---: |"]
    for p, b, n, tol, z, err, wall in rows:
        name = "%s refined %dx" % (os.path.basename(model["mesh"]), b) if model else "%dx%dx%d" % (4 * b, b, b)
        md.append("| %d | %s | %d | %s | %.6f | %.2e | %.2f |" % (
            p, name, n, "direct" if p == 1 else "%g" % tol, z, err, wall))
    for name, text in ((a.out + ".csv", csv), (a.out + ".md", "\n".join(md) + "\n")):
        with open(name + ".tmp", "w") as f:
            f.write(text)
        os.replace(name + ".tmp", name)
    print("\n".join(md))

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 5))
    for p, marker in ((1, "o"), (2, "s"), (3, "^")):
        for tol in sorted(set(r[3] for r in rows if r[0] == p)):
            pts = sorted((r[6], r[5]) for r in rows if r[0] == p and r[3] == tol)
            ax.loglog([t for t, _ in pts], [e for _, e in pts], marker=marker,
                      label="p = %d" % p + ("" if p == 1 else ", tol %g" % tol))
    ax.set_xlabel("run time [s]")
    ax.set_ylabel("relative error of the probe's displacement")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(a.out + ".png.tmp.png", dpi=110)
    os.replace(a.out + ".png.tmp.png", a.out + ".png")
    print("wrote %s.csv, %s.md, %s.png" % (a.out, a.out, a.out))


if __name__ == "__main__":
    main()
