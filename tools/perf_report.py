"""The p-multigrid performance targets in one run: ratios against the strongest alternatives
measured in the same run, the bandwidth bound beside the assembled V-cycle.

  1. static cubic Homer to 1e-6 from zero: the best multigrid (PMG or MGPCG, default settings)
     against CHOLMOD (factor + solve) and block-Jacobi PCG;
  2. the unit cube, p = 2, a sweep of sizes to 1e-6: the best multigrid at the largest size
     against block-Jacobi PCG and CHOLMOD, and the fitted exponent k of time ~ n^k, with its
     spread over repeated sweeps (the later sweeps run the multigrid solvers only);
  3. the twisted cubic Homer (corotational, dt 0.01, 1e-3 per step, 10 steps): wall time per step
     of the default against the default of before (assembled Gauss-Seidel PMG, threaded BLAS), its
     solve per step against block-Jacobi PCG's, and its step against a CHOLMOD-per-step run;
  4. the assembled cubic V-cycle against its bytes-moved / read-bandwidth bound
     (bench/multigrid/bench_vcycle), on 2 threads and on 1;
  5. assembly per step (finest matrix or operator update + hierarchy update) of the default
     against the default of before, and elements per second;
  6. scale: the default MGPCG on the unit cube, p = 2, from 0.29M to 4.5M unknowns (boxes
     14..35), each size in its own process as a user runs it (no warm-up): time to 1e-6, set-up
     share, peak memory per unknown (/usr/bin/time), the fitted exponent with its spread over
     --repeats sweeps, the 515k cube against block-Jacobi PCG in one run, and with --largest N the
     cube of N boxes (N = 46: 10.2M unknowns) with its load + set-up against its solve and its
     whole job (load + t(1e-6)) against 30 s; the exponent of the whole job; --scale-refine K
     refines each cube K times (its coarser meshes then carry the linear level: coarse_meshes);
     plots time, set-up share and the whole job by part (load, set-up, solve) against size (the
     seed's Fig. 2.31 re-drawn) to OUT.scale.png, the figures (load and set-up by stage) to
     OUT.scale.csv.

Every figure comes from `pmg compare --json`, `pmg simulate --json` or the benchmark's summary
line of this run. Needs models/homer.ele (scripts/get_models.sh) unless --quick, which runs
every part on small box meshes in seconds (a smoke test: its ratios mean nothing). Writes the
table as Markdown to --out (atomically) and prints it:

  /usr/bin/python3 tools/perf_report.py --pmg build/tools/pmg --out perf_report.md   # ~15 min
  /usr/bin/python3 tools/perf_report.py --parts 6 --largest 46 --out scale.md           # ~12 min
  /usr/bin/python3 tools/perf_report.py --parts 6 --scale-boxes 7,9,11,14,18 --scale-refine 1 --largest 24 --out scale.md
"""
import argparse
import json
import math
import os
import re
import subprocess
import sys
import tempfile

from pmgreport import atomic_write, error_line, run

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# The default of before these targets were set: the seed's assembled Gauss-Seidel PMG with the
# BLAS under CHOLMOD left threaded.
BEFORE = {"method": "pmg", "operator": "assembled", "lowest_level": {"blas_threads": 0}}


def log(*args):
    print(*args, file=sys.stderr, flush=True)


def compare(pmg, args, solvers, tol):
    cmd = [pmg, "compare"] + args + ["-t", str(tol), "--warm-up", "--no-reference", "--solvers", solvers]
    log("$", " ".join(cmd))
    proc, report = run(cmd)
    if report is None:
        sys.exit("perf_report: pmg compare failed: %s" % (error_line(proc) or proc.stderr[-500:]))
    key = "time_to_1e-6_s" if tol <= 1e-6 else "time_to_1e-3_s"
    times = {}
    for s in report["solvers"]:
        if s["status"] != "converged" or s[key] is None:
            sys.exit("perf_report: %s did not converge (%s)" % (s["name"], s["message"]))
        times[s["name"]] = (s[key], s["iterations"])
    return report["system"]["unknowns"], times


def simulate(pmg, scene, solver, duration, workdir, name):
    sc = dict(scene)
    sc["solver"] = dict(solver)
    path = os.path.join(workdir, name + ".json")
    with open(path, "w") as f:
        json.dump(sc, f)
    cmd = [pmg, "simulate", path, "-q", "--duration", str(duration)]
    log("$", " ".join(cmd), " # solver", json.dumps(solver))
    proc, report = run(cmd)
    if report is None or proc.returncode != 0:
        sys.exit("perf_report: pmg simulate failed: %s" % (error_line(proc) or proc.stderr[-500:]))
    steps = report["steps"]["done"]
    stage = {s["stage"]: s["per_step_ms"] for s in report["stages"]}
    return {"wall_ms": 1e3 * report["steps"]["wall_s"] / steps, "solve_ms": stage["solve"],
            "assembly_ms": stage.get("finest matrix", 0.0) + stage.get("hierarchy update", 0.0),
            "tets": report["mesh"]["tets"], "iterations": report["steps"]["iterations_per_step"]}


def vcycle(bench, threads, quick):
    cmd = [bench] + (["--pmg_boxes=1", "--benchmark_min_time=0.001", "--benchmark_repetitions=1",
                      "--pmg_triad_mib=8"] if quick else [])
    log("$ OMP_NUM_THREADS=%d" % threads, " ".join(cmd))
    env = dict(os.environ, OMP_NUM_THREADS=str(threads))
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env)
    m = re.search(r"V-cycle: ([0-9.]+) ms measured, [0-9.]+ MB moved at least, bound ([0-9.]+) ms", proc.stdout)
    if proc.returncode != 0 or not m:
        sys.exit("perf_report: %s failed (exit %d): %s" % (bench, proc.returncode, proc.stderr[-500:]))
    return float(m.group(1)), float(m.group(2))


def cube_run(pmg, n, solvers, warm_up, refine=0):
    """One `pmg compare` of the P2 unit cube of n^3 boxes (refined `refine` times) in its own
    process: (report, peak bytes or None where /usr/bin/time is missing)."""
    cmd = [pmg, "compare", "--box", str(n), str(n), str(n), "--size", "1", "1", "1", "-p", "2", "--fix", "z",
           "--load", "gravity", "--tol", "1e-6", "--no-reference", "--solvers", solvers] + (["--warm-up"] if warm_up else [])
    if refine:
        cmd += ["--refine", str(refine)]
    with tempfile.TemporaryDirectory() as d:
        peak_file = os.path.join(d, "peak")
        timed = os.path.exists("/usr/bin/time")
        full = (["/usr/bin/time", "-f", "%M", "-o", peak_file] if timed else []) + cmd
        log("$", " ".join(cmd))
        proc, report = run(full)
        if report is None or proc.returncode != 0:
            sys.exit("perf_report: pmg compare failed for %d boxes: %s" % (n, error_line(proc) or proc.stderr[-500:]))
        peak = None
        if timed:
            with open(peak_file) as f:
                peak = 1024.0 * float(f.read().split()[-1])
    return report, peak


def scale(a, rows):
    """Part 6 (see the file comment): rows of the table, and OUT.scale.csv / OUT.scale.png."""
    sweep_boxes = [2, 3, 4] if a.quick else [int(b) for b in a.scale_boxes.split(",")]
    boxes = sorted(set(sweep_boxes + ([a.largest] if a.largest else [])))
    # (repeat, boxes, unknowns, t(1e-6), setup, iterations, peak bytes, setup breakdown, load, load stages)
    data = []
    for r in range(a.repeats):
        for n in boxes:
            if r > 0 and n not in sweep_boxes:
                continue  # the largest cube once
            report, peak = cube_run(a.pmg, n, "mgpcg", False, a.scale_refine)
            s = report["solvers"][0]
            if s["status"] != "converged":
                sys.exit("perf_report: mgpcg did not converge on %d boxes (%s)" % (n, s["message"]))
            stages = "; ".join("%s %.3f s" % (x["stage"], x["seconds"]) for x in report.get("load_stages", []))
            data.append((r, n, report["system"]["unknowns"], s["time_to_1e-6_s"], s["setup_s"], s["iterations"], peak,
                         s.get("setup_breakdown", ""), report.get("load_s", 0.0), stages))
    swept = [d for d in data if d[1] in sweep_boxes]  # the fit: the sweep's sizes only
    exps = []
    for r in range(a.repeats):
        pts = [(d[2], d[3]) for d in swept if d[0] == r]
        exps.append(fit([u for u, _ in pts], [t for _, t in pts]))
    first = [d for d in swept if d[0] == 0]
    whole_exps = [fit([d[2] for d in swept if d[0] == r], [d[3] + d[8] for d in swept if d[0] == r]) for r in range(a.repeats)]
    spread = "; sweeps %s" % ", ".join("%.2f" % k for k in exps) if a.repeats > 1 else ""
    k = max(exps)
    if math.isnan(k):
        rows.append(("6", "fitted exponent (needs 3 sizes or more)", "-", "-", "<= 1.05", "not measured"))
    else:
        rows.append(("6", "exponent k of time to 1e-6 ~ n^k, default MGPCG, %d sizes %.2fM-%.2fM unknowns (largest of the sweeps%s)"
                     % (len(first), first[0][2] / 1e6, first[-1][2] / 1e6, spread), "k = %.2f" % k, "-", "<= 1.05",
                     "met" if k <= 1.05 else "not met"))
    if not math.isnan(max(whole_exps)):
        kw = max(whole_exps)
        rows.append(("6", "exponent of the whole job (load + set-up + solve to 1e-6) ~ n^k (largest of the sweeps; %s)"
                     % ", ".join("%.2f" % k for k in whole_exps), "k = %.2f" % kw, "-", "<= 1.05",
                     "met" if kw <= 1.05 else "not met"))
    big = [d for d in first if d[2] >= 1e6]
    if big:
        worst = max(big, key=lambda d: d[4] / d[3])
        rows.append(("6", "largest set-up share at >= 1M unknowns: %.0f%% at %d unknowns (set-up %.2f s of %.2f s)"
                     % (100 * worst[4] / worst[3], worst[2], worst[4], worst[3]), "%.0f%%" % (100 * worst[4] / worst[3]),
                     "-", "<= 35%", "met" if worst[4] / worst[3] <= 0.35 else "not met"))
    if first[0][6] is not None:
        near = min(first, key=lambda d: abs(d[2] - 2.3e6))
        kb = near[6] / near[2] / 1e3
        rows.append(("6", "peak memory per unknown at %d unknowns: %.2f GB" % (near[2], near[6] / 1e9), "%.2f KB" % kb,
                     "-", "<= 1.5 KB", "met" if kb <= 1.5 else "not met"))
    if a.largest:
        d = [d for d in data if d[1] == a.largest][0]
        rows.append(("6", "largest cube: %d boxes%s, %d unknowns, to 1e-6 in %.1f s (%d it., set-up %.1f s)%s"
                     % (d[1], " refined %dx" % a.scale_refine if a.scale_refine else "", d[2], d[3], d[5], d[4],
                        "" if d[6] is None else ", peak %.1f GB" % (d[6] / 1e9)),
                     "%.1fM unknowns" % (d[2] / 1e6), "-", ">= 10M", "met" if d[2] >= 10e6 else "not met"))
        solve = d[3] - d[4]
        rows.append(("6", "largest cube, load + set-up against the solve: load %.1f s (%s), set-up %.1f s, solve %.1f s"
                     % (d[8], d[9], d[4], solve), "%.1f s" % (d[8] + d[4]), "%.2fx the solve" % ((d[8] + d[4]) / solve),
                     "<= the solve", "met" if d[8] + d[4] <= solve else "not met"))
        rows.append(("6", "largest cube, the whole job: load + set-up + solve to 1e-6", "%.1f s" % (d[8] + d[3]), "-",
                     "<= 30 s", "met" if d[8] + d[3] <= 30 else "not met"))
    n515 = 3 if a.quick else 17
    report, _ = cube_run(a.pmg, n515, "mgpcg,block-jacobi-pcg", True)
    t = {s["name"]: s for s in report["solvers"]}
    for name in ("mgpcg", "block-jacobi-pcg"):
        if t[name]["time_to_1e-6_s"] is None:
            sys.exit("perf_report: %s did not reach 1e-6 on %d boxes (%s)" % (name, n515, t[name]["message"]))
    ratio = t["block-jacobi-pcg"]["time_to_1e-6_s"] / t["mgpcg"]["time_to_1e-6_s"]
    rows.append(("6", "cube %d unknowns, one run (warm-up): mgpcg %.2f s (%d it.) vs block-Jacobi PCG %.2f s (%d it.)"
                 % (report["system"]["unknowns"], t["mgpcg"]["time_to_1e-6_s"], t["mgpcg"]["iterations"],
                    t["block-jacobi-pcg"]["time_to_1e-6_s"], t["block-jacobi-pcg"]["iterations"]),
                 "%.2f s" % t["mgpcg"]["time_to_1e-6_s"], "%.2fx" % ratio, ">= 3x", "met" if ratio >= 3 else "not met"))
    base = os.path.splitext(a.out)[0] + ".scale"
    atomic_write(base + ".csv", "sweep,boxes,refine,unknowns,load_s,time_to_1e-6_s,setup_s,iterations,peak_bytes,"
                 "load_stages,setup_breakdown\n" + "".join(
        "%d,%d,%d,%d,%.6g,%.6g,%.6g,%d,%s,\"%s\",\"%s\"\n" % (r, n, a.scale_refine, u, ld, t6, st, it,
                                                         "" if pk is None else "%d" % pk, ls, bd)
        for r, n, u, t6, st, it, pk, bd, ld, ls in data))
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax1, ax2, ax3) = plt.subplots(1, 3, figsize=(16, 4.2))
    for r in range(a.repeats):
        pts = sorted((d[2], d[3]) for d in data if d[0] == r)
        ax1.loglog([u for u, _ in pts], [t for _, t in pts], marker="o", label="sweep %d (k = %.2f)" % (r + 1, exps[r]))
    u0, t0 = first[0][2], first[0][3]
    us = [d[2] for d in data]
    ax1.loglog([min(us), max(us)], [t0 * min(us) / u0, t0 * max(us) / u0], "k--", lw=0.8, label="linear")
    ax1.set_xlabel("unknowns (degree 2)")
    ax1.set_ylabel("time to 1e-6 incl. set-up [s]")
    ax1.grid(True, which="both", alpha=0.3)
    ax1.legend(fontsize=8)
    pts = sorted((d[2], 100 * d[4] / d[3]) for d in data if d[0] == 0)
    ax2.semilogx([u for u, _ in pts], [s for _, s in pts], marker="o")
    ax2.axhline(35, color="k", ls="--", lw=0.8)
    ax2.set_xlabel("unknowns (degree 2)")
    ax2.set_ylabel("set-up share of the time [%]")
    ax2.set_ylim(0, 100)
    ax2.grid(True, which="both", alpha=0.3)
    # The whole job by part, per size (the first sweep): load, set-up, solve.
    pts = sorted((d[2], d[8], d[4], d[3] - d[4]) for d in data if d[0] == 0)
    xs = range(len(pts))
    ax3.bar(xs, [p[1] for p in pts], label="load (mesh, spaces, hierarchy)")
    ax3.bar(xs, [p[2] for p in pts], bottom=[p[1] for p in pts], label="set-up")
    ax3.bar(xs, [p[3] for p in pts], bottom=[p[1] + p[2] for p in pts], label="solve to 1e-6")
    ax3.set_xticks(list(xs))
    ax3.set_xticklabels(["%.1fM" % (p[0] / 1e6) for p in pts], fontsize=8)
    ax3.set_xlabel("unknowns (degree 2)")
    ax3.set_ylabel("seconds")
    ax3.legend(fontsize=8)
    ax3.grid(True, axis="y", alpha=0.3)
    fig.suptitle("default MGPCG, P2 unit cube%s, %s threads" % (
        " refined %dx" % a.scale_refine if a.scale_refine else "", os.environ.get("OMP_NUM_THREADS", str(os.cpu_count()))))
    fig.tight_layout()
    fd, tmp = tempfile.mkstemp(dir=os.path.dirname(os.path.abspath(base)), prefix=".tmp_", suffix=".png")
    os.close(fd)
    fig.savefig(tmp, dpi=110)
    os.replace(tmp, base + ".png")
    log("wrote %s.csv, %s.png" % (base, base))


def fit(ns, ts):
    if len(ns) < 3:
        return float("nan")
    import numpy as np

    return float(np.polyfit(np.log(ns), np.log(ts), 1)[0])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--pmg", default=os.path.join(ROOT, "build/tools/pmg"))
    ap.add_argument("--vcycle", default=None, help="bench_vcycle (default: next to pmg, ../bench/multigrid)")
    ap.add_argument("--mesh", default=os.path.join(ROOT, "models/homer.ele"), help="the cubic model of targets 1, 3 and 5")
    ap.add_argument("--boxes", default="5,7,9,11,14,17", help="target 2: boxes per side of the cube")
    ap.add_argument("--repeats", type=int, default=2, help="target 2: sweeps (the later ones multigrid only)")
    ap.add_argument("--quick", action="store_true", help="small box meshes everywhere (a smoke test)")
    ap.add_argument("--parts", default="1,2,3,4,5,6", help="which parts to run (see above)")
    ap.add_argument("--scale-boxes", default="14,17,22,28,35", help="part 6: boxes per side of the swept cubes")
    ap.add_argument("--largest", type=int, default=0, help="part 6: also the cube of this many boxes per side, once")
    ap.add_argument("--scale-refine", type=int, default=0,
                    help="part 6: refine each cube's mesh this many times (its coarser meshes then carry the "
                         "linear level's multigrid: coarse_meshes)")
    ap.add_argument("--out", default="perf_report.md")
    a = ap.parse_args()
    if a.repeats < 1:
        sys.exit("perf_report: --repeats must be >= 1")
    bench = a.vcycle or os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(a.pmg))),
                                     "bench", "multigrid", "bench_vcycle")
    if "4" in a.parts.split(",") and not os.path.exists(bench):
        sys.exit("perf_report: %s not found (--vcycle)" % bench)
    if a.quick:
        model = ["--box", "3", "1", "1", "-p", "3", "--fix", "x", "--load", "gravity"]
        scene = {"name": "twisted bar (quick)", "mesh": {"box": [3, 1, 1], "size": [3, 1, 1]}, "degree": 3,
                 "material": {"model": "corotational", "young": 5e6, "poisson": 0.3, "density": 1000},
                 "clamp": {"axis": "x", "fraction": 0.0}, "initial": {"state": "twisted", "degrees": 30},
                 "time": {"dt": 0.01, "duration": 0.03}}
        boxes, duration = [1, 2, 3], 0.03
    else:
        if set(a.parts.split(",")) & {"1", "3", "5"} and not os.path.exists(a.mesh):
            sys.exit("perf_report: %s not found: run scripts/get_models.sh (or pass --mesh)" % a.mesh)
        model = ["--mesh", a.mesh, "-p", "3", "--fix", "z", "--fix-fraction", "0.05", "--load", "gravity"]
        with open(os.path.join(ROOT, "scenes/homer_twisted.json")) as f:
            scene = json.load(f)  # (its mesh is replaced below)
        scene["mesh"] = {"file": os.path.abspath(a.mesh)}
        boxes, duration = [int(b) for b in a.boxes.split(",")], 0.1
    rows = []  # (target, what, measured, ratio text, goal text, met)

    def row(target, what, measured, ratio, goal, at_least=True):
        """ratio against goal: met when ratio >= goal (at_least) or ratio <= goal."""
        met = ratio >= goal if at_least else ratio <= goal
        rows.append((target, what, measured, "%.2fx" % ratio, (">= %gx" if at_least else "<= %gx") % goal,
                     "met" if met else "not met"))

    parts = set(p.strip() for p in a.parts.split(","))
    if not parts or not parts <= {"1", "2", "3", "4", "5", "6"}:
        sys.exit("perf_report: --parts takes numbers 1..6 separated by commas, got %r" % a.parts)
    if "1" in parts:
        # 1. static Homer
        n1, t = compare(a.pmg, model, "cholmod,block-jacobi-pcg,pmg,mgpcg", 1e-6)
        best = min(("pmg", "mgpcg"), key=lambda s: t[s][0])
        tb = t[best][0]
        row("1", "static, %d unknowns, to 1e-6: %s %.2f s (%d it.) vs CHOLMOD %.2f s" % (n1, best, tb, t[best][1], t["cholmod"][0]),
            "%.2f s" % tb, t["cholmod"][0] / tb, 3.0)
        row("1", "%s vs block-Jacobi PCG %.2f s (%d it.)" % (best, t["block-jacobi-pcg"][0], t["block-jacobi-pcg"][1]),
            "%.2f s" % tb, t["block-jacobi-pcg"][0] / tb, 5.0)

    if "2" in parts:
        # 2. cube sweep, p = 2
        sizes, mg_times, last = [], {}, None
        for r in range(a.repeats):
            solvers = "pmg,mgpcg,block-jacobi-pcg,cholmod" if r == 0 else "pmg,mgpcg"
            for n in boxes:
                u, tt = compare(a.pmg, ["--box", str(n), str(n), str(n), "--size", "1", "1", "1", "-p", "2",
                                        "--fix", "z", "--load", "gravity"], solvers, 1e-6)
                if r == 0:
                    sizes.append(u)
                    last = tt
                mg_times.setdefault(r, []).append(min(tt["pmg"][0], tt["mgpcg"][0]))
        exps = [fit(sizes, mg_times[r]) for r in range(a.repeats)]
        best2 = min(("pmg", "mgpcg"), key=lambda s: last[s][0])
        tl = last[best2][0]
        row("2", "cube p=2, %d unknowns, to 1e-6: %s %.2f s vs block-Jacobi PCG %.2f s" % (sizes[-1], best2, tl, last["block-jacobi-pcg"][0]),
            "%.2f s" % tl, last["block-jacobi-pcg"][0] / tl, 3.0)
        row("2", "%s vs CHOLMOD %.2f s" % (best2, last["cholmod"][0]), "%.2f s" % tl, last["cholmod"][0] / tl, 10.0)
        if any(math.isnan(k) for k in exps):
            rows.append(("2", "fitted exponent (needs 3 sizes or more)", "-", "-", "<= 1.1", "not measured"))
        else:
            spread = "" if a.repeats < 2 else "; sweeps %s" % ", ".join("%.2f" % k for k in exps)
            rows.append(("2", "exponent k of time ~ n^k, best multigrid, %d sizes (largest of the sweeps%s)" % (len(sizes), spread),
                         "k = %.2f" % max(exps), "-", "<= 1.1", "met" if max(exps) <= 1.1 else "not met"))

    if parts & {"3", "5"}:
        # 3 and 5. the twisted model
        with tempfile.TemporaryDirectory() as d:
            now = simulate(a.pmg, scene, {"method": "mgpcg", "tol": 1e-3}, duration, d, "default")
            before = simulate(a.pmg, scene, dict(BEFORE, tol=1e-3), duration, d, "before")
            if "3" in parts:
                bj = simulate(a.pmg, scene, {"method": "block-jacobi-pcg", "tol": 1e-3}, duration, d, "bjpcg")
                chol = simulate(a.pmg, scene, {"method": "cholmod"}, duration, d, "cholmod")
    if "3" in parts:
        row("3", "twisted, wall per step: default (mgpcg) %.0f ms vs before (assembled PMG) %.0f ms" % (now["wall_ms"], before["wall_ms"]),
            "%.0f ms" % now["wall_ms"], before["wall_ms"] / now["wall_ms"], 4.0)
        row("3", "solve per step: %.0f ms (%.1f it.) vs block-Jacobi PCG %.0f ms (%.0f it.)" % (now["solve_ms"], now["iterations"], bj["solve_ms"], bj["iterations"]),
            "%.0f ms" % now["solve_ms"], bj["solve_ms"] / now["solve_ms"], 5.0)
        row("3", "wall per step vs CHOLMOD per step %.0f ms" % chol["wall_ms"], "%.0f ms" % now["wall_ms"],
            chol["wall_ms"] / now["wall_ms"], 6.0)

    if "4" in parts:
        # 4. the assembled V-cycle
        c2, b2 = vcycle(bench, 2, a.quick)
        c1, _ = vcycle(bench, 1, a.quick)
        row("4", "assembled cubic V-cycle, 2 threads: %.1f ms against its bound %.1f ms" % (c2, b2), "%.1f ms" % c2, c2 / b2, 1.25,
            at_least=False)
        row("4", "the same on 1 thread: %.1f ms (ratio: 1 thread / 2 threads)" % c1, "%.1f ms" % c1, c1 / c2, 1.05)

    if "5" in parts:
        # 5. assembly per step
        row("5", "assembly per step (finest + hierarchy update): default %.1f ms vs before %.1f ms; %d elements, %.3g elements/s"
            % (now["assembly_ms"], before["assembly_ms"], now["tets"], now["tets"] / max(now["assembly_ms"], 1e-9) * 1e3),
            "%.1f ms" % now["assembly_ms"], before["assembly_ms"] / max(now["assembly_ms"], 1e-9), 4.0)

    if "6" in parts:
        scale(a, rows)

    lines = ["| target | what | measured | ratio | goal | |", "| --- | --- | ---: | ---: | --- | --- |"]
    lines += ["| %s |" % " | ".join(r) for r in rows]
    threads = os.environ.get("OMP_NUM_THREADS", str(os.cpu_count() or 1))
    table = "\n".join(lines) + "\n\n(" + ("--quick: small box meshes, the ratios mean nothing; " if a.quick else "") + \
        "%s threads; times include set-up; `/usr/bin/python3 tools/perf_report.py`)\n" % threads
    atomic_write(a.out, table)
    print(table)
    print("wrote", a.out)


if __name__ == "__main__":
    main()
