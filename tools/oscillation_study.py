"""The seed's Fig. 2.29: an undamped oscillating bar simulated with different per-step solvers.

Reads the steps.csv files that `pmg simulate` writes, finds the extremes of the probe's z
displacement, and reports per run: the measured period, the amplitude lost per period, the energy
left at the end, the mean solver iterations and time per step. It also prints what implicit Euler
alone removes from a mode of that period, (1 + ω²Δt²)^(-T/2Δt) per period, so the damping the
solver adds can be told from the integrator's own. Writes <out>.md and <out>.png (matplotlib):

  /usr/bin/python3 tools/oscillation_study.py --out docs/fig229 pmg=fig229_pmg/steps.csv \
      cg20=fig229_cg20/steps.csv
"""
import argparse
import csv
import math
import os
import tempfile


def load(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    col = lambda k: [float(r[k]) for r in rows]
    stage_cols = [k for k in rows[0] if k.endswith("_s")]
    step_time = [sum(float(r[k]) for k in stage_cols) for r in rows[1:]]
    return {"t": col("time"), "z": col("probe_uz"), "E": col("total_energy"),
            "it": col("iterations")[1:], "step_time": step_time}


def extremes(t, z):
    """(time, value) of the local extremes of z, excluding the start."""
    out = []
    for i in range(1, len(z) - 1):
        if (z[i] - z[i - 1]) * (z[i + 1] - z[i]) < 0:
            out.append((t[i], z[i]))
    return out


def analyse(run, dt):
    ex = extremes(run["t"], run["z"])
    mins = [e for e in ex if e[1] < 0]
    maxs = [e for e in ex if e[1] > 0]
    # Period: mean spacing of same-sign extremes; amplitude loss: geometric mean of the ratio of
    # successive same-sign extremes, per period.
    periods, ratios = [], []
    for seq in (mins, maxs):
        for a, b in zip(seq, seq[1:]):
            periods.append(b[0] - a[0])
            ratios.append(abs(b[1]) / abs(a[1]))
    T = sum(periods) / len(periods) if periods else float("nan")
    loss = 1 - math.exp(sum(math.log(r) for r in ratios) / len(ratios)) if ratios else float("nan")
    w = 2 * math.pi / T if T == T else float("nan")
    euler = 1 - (1 + (w * dt) ** 2) ** (-T / (2 * dt)) if T == T else float("nan")
    return T, loss, euler


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("runs", nargs="+", help="label=path/to/steps.csv")
    ap.add_argument("--out", default="fig229")
    a = ap.parse_args()
    runs = {}
    for spec in a.runs:
        label, path = spec.split("=", 1)
        runs[label] = load(path)
    lines = ["| run | period [s] | amplitude lost per period | implicit Euler alone | energy left at %.0f s | iterations per step | time per step [ms] |" % max(r["t"][-1] for r in runs.values()),
             "| --- | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for label, r in runs.items():
        dt = r["t"][1] - r["t"][0]
        T, loss, euler = analyse(r, dt)
        lines.append("| %s | %.3f | %.1f%% | %.1f%% | %.1f%% | %.1f | %.1f |" % (
            label, T, 100 * loss, 100 * euler, 100 * r["E"][-1] / r["E"][0],
            sum(r["it"]) / len(r["it"]), 1e3 * sum(r["step_time"]) / len(r["step_time"])))
    table = "\n".join(lines) + "\n"
    print(table)
    fd, tmp = tempfile.mkstemp(dir=os.path.dirname(os.path.abspath(a.out)) or ".", prefix=".tmp_")
    with os.fdopen(fd, "w") as f:
        f.write(table)
    os.replace(tmp, a.out + ".md")

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(12, 4.5))
    for label, r in runs.items():
        ax1.plot(r["t"], r["z"], label=label)
        ax2.plot(r["t"], [e / r["E"][0] for e in r["E"]], label=label)
    ax1.set_xlabel("time [s]")
    ax1.set_ylabel("tip displacement z [m]")
    ax2.set_xlabel("time [s]")
    ax2.set_ylabel("total energy / initial")
    for ax in (ax1, ax2):
        ax.grid(True, alpha=0.3)
        ax.legend()
    fig.tight_layout()
    fd, tmp = tempfile.mkstemp(dir=os.path.dirname(os.path.abspath(a.out)) or ".", prefix=".tmp_", suffix=".png")
    os.close(fd)
    fig.savefig(tmp, dpi=110)
    os.replace(tmp, a.out + ".png")
    print("wrote %s.md, %s.png" % (a.out, a.out))


if __name__ == "__main__":
    main()
