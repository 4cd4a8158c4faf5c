"""Time to solution against problem size (the seed's Fig. 2.31), with a fitted exponent per solver.

Runs `pmg compare` on the unit cube of n^3 boxes (24 tets each), clamped at z = 0, under gravity,
for each n, and reads the residual histories it writes. For every solver it records the time
(set-up included) and the iterations to each tolerance, fits time ~ c n^k by least squares in
log-log over the sizes where the solver reached the tolerance, and writes a CSV, a PNG and a
Markdown table. Needs Debian's python3 (numpy, matplotlib):

  /usr/bin/python3 tools/size_sweep.py --pmg build/tools/pmg --boxes 5,7,9,11,14,17 -p 2 \
      --solvers pmg,mgpcg,block-jacobi-pcg,cholmod,boomeramg-pcg --out sweep

--variant LABEL=ARGS (repeatable) runs `pmg compare` once more per size with extra arguments and
reports its solvers as SOLVER[LABEL], e.g. PMG with BoomerAMG on the linear level:

  --variant "amg=--solvers pmg --set lowest_level=boomeramg-pcg"
"""
import argparse
import csv
import math
import os
import sys
import tempfile

from pmgreport import atomic_write, run


def first_reach(rows, tol):
    for it, sec, res in rows:
        if res <= tol:
            return it, sec
    return None, None


def fit(ns, ts):
    import numpy as np

    if len(ns) < 3:
        return float("nan")
    k, _ = np.polyfit(np.log(ns), np.log(ts), 1)
    return float(k)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--pmg", default="build/tools/pmg")
    ap.add_argument("--boxes", default="5,7,9,11,14,17", help="boxes per side of the cube")
    ap.add_argument("-p", "--degree", type=int, default=2)
    ap.add_argument("--solvers", default="pmg,mgpcg,block-jacobi-pcg,cholmod,boomeramg-pcg")
    ap.add_argument("--tols", default="1e-3,1e-6")
    ap.add_argument("--out", default="sweep", help="prefix of the .csv, .png and .md outputs")
    ap.add_argument("--max-iter", type=int, default=20000)
    ap.add_argument("--no-warm-up", action="store_true",
                    help="time each solver's first run (by default pmg compare --warm-up runs each "
                         "once untimed first, so no solver pays the process's first memory touches)")
    ap.add_argument("--variant", action="append", default=[], metavar="LABEL=ARGS",
                    help="another pmg compare run per size with these extra arguments (its --solvers "
                         "replaces the default); its solvers are reported as SOLVER[LABEL]")
    a = ap.parse_args()
    runs = [("", [])]
    for v in a.variant:
        label, sep, args = v.partition("=")
        if not sep or not label:
            sys.exit("size_sweep: --variant needs LABEL=ARGS, got %r" % v)
        runs.append(("[%s]" % label, args.split()))
    tols = [float(t) for t in a.tols.split(",")]
    rows = []  # (n_boxes, unknowns, solver, tol, iterations, seconds)
    for n, (suffix, extra) in ((n, r) for n in [int(x) for x in a.boxes.split(",")] for r in runs):
        with tempfile.TemporaryDirectory() as d:
            hist = os.path.join(d, "h.csv")
            cmd = [a.pmg, "compare", "--box", str(n), str(n), str(n), "--size", "1", "1", "1",
                   "-p", str(a.degree), "--fix", "z", "--load", "gravity", "--tol", str(min(tols)),
                   "--no-reference", "--max-iter", str(a.max_iter), "--history", hist]
            if not a.no_warm_up:
                cmd.append("--warm-up")
            cmd += extra if "--solvers" in extra else extra + ["--solvers", a.solvers]
            print("$", " ".join(cmd), flush=True)
            p, report = run(cmd)
            print(p.stdout, p.stderr, sep="", flush=True)
            if report is None or not os.path.exists(hist):
                sys.exit("size_sweep: pmg compare failed for n = %d (exit %d)" % (n, p.returncode))
            unknowns = report["system"]["unknowns"]
            hist_rows = {}
            with open(hist) as f:
                for r in csv.DictReader(f):
                    hist_rows.setdefault(r["solver"] + suffix, []).append(
                        (int(r["iteration"]), float(r["seconds"]), float(r["rel_residual"])))
            for solver, hr in hist_rows.items():
                for tol in tols:
                    it, sec = first_reach(hr, tol)
                    rows.append((n, unknowns, solver, tol, it, sec))
    text = "boxes,unknowns,solver,tol,iterations,seconds\n" + "".join(
        "%d,%d,%s,%g,%s,%s\n" % (n, u, s, t, "" if i is None else i, "" if c is None else "%.6g" % c)
        for n, u, s, t, i, c in rows)
    atomic_write(a.out + ".csv", text)

    solvers = list(dict.fromkeys(r[2] for r in rows))
    sizes = sorted(set(r[1] for r in rows))
    md = ["| solver | tol | " + " | ".join("%dk" % round(u / 1000) for u in sizes) + " | exponent |",
          "| --- | --- | " + " | ".join("---:" for _ in sizes) + " | ---: |"]
    exps = {}
    for s in solvers:
        for tol in tols:
            pts = {r[1]: r for r in rows if r[2] == s and r[3] == tol}
            ok = [(u, pts[u][5]) for u in sizes if u in pts and pts[u][5] is not None]
            k = fit([u for u, _ in ok], [t for _, t in ok])
            exps[(s, tol)] = k
            cells = []
            for u in sizes:
                r = pts.get(u)
                cells.append("-" if r is None or r[5] is None else "%.3g s (%d)" % (r[5], r[4]))
            md.append("| %s | %g | %s | %s |" % (s, tol, " | ".join(cells), "-" if math.isnan(k) else "%.2f" % k))
    table = "\n".join(md) + "\n\n(time to the tolerance incl. set-up, iterations or cycles in brackets; exponent k of a\nleast-squares fit time ~ n^k over the sizes reached)\n"
    atomic_write(a.out + ".md", table)
    print(table)

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(tols), figsize=(6 * len(tols), 4.5))
    axes = axes if len(tols) > 1 else [axes]
    for ax, tol in zip(axes, tols):
        for s in solvers:
            pts = [(r[1], r[5]) for r in rows if r[2] == s and r[3] == tol and r[5] is not None]
            if pts:
                ax.loglog([u for u, _ in pts], [t for _, t in pts], marker="o",
                          label="%s (k = %.2f)" % (s, exps[(s, tol)]))
        ax.set_xlabel("unknowns (degree %d)" % a.degree)
        ax.set_ylabel("time to %g incl. set-up [s]" % tol)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    d = os.path.dirname(os.path.abspath(a.out + ".png"))
    fd, tmp = tempfile.mkstemp(dir=d, prefix=".tmp_", suffix=".png")
    os.close(fd)
    fig.savefig(tmp, dpi=110)
    os.replace(tmp, a.out + ".png")
    print("wrote %s.csv, %s.md, %s.png" % (a.out, a.out, a.out))


if __name__ == "__main__":
    main()
