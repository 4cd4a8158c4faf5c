"""Residual-against-time and residual-against-iterations plots from a pmg compare history CSV
(solver,iteration,seconds,rel_residual), like the seed's Figs. 2.30 and 2.32; with --summary, a
third panel: error against time, one labelled point per solver (a work-precision view).
Usage: /usr/bin/python3 plot_history.py history.csv out.png [title] [--summary summary.csv]
The summary CSV (pmg compare --plot writes it) has the header
solver,seconds,error,rel_residual,iterations: seconds the time to the tolerance including set-up,
error the relative error against the reference solution; either may be empty (a failed solver, no
reference). Where the error is empty the point is the final relative residual, and the axis says so."""
import csv
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

USAGE = "usage: /usr/bin/python3 plot_history.py history.csv out.png [title] [--summary summary.csv]"


def split_args(argv):
    """(positionals, summary path or None): --summary PATH / --summary=PATH anywhere after them."""
    rest, summary, i = [], None, 0
    while i < len(argv):
        a = argv[i]
        if a == "--summary":
            if i + 1 >= len(argv):
                sys.exit("plot: --summary needs a file")
            summary, i = argv[i + 1], i + 2
            continue
        if a.startswith("--summary="):
            summary = a[len("--summary="):]
        else:
            rest.append(a)
        i += 1
    if len(rest) not in (2, 3):
        sys.exit(USAGE)
    return rest, summary


def number(text):
    """A finite float from a CSV field, else None (empty, nan, inf, garbage)."""
    try:
        v = float(text)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def read_summary(path):
    """[(solver, seconds, value, is_error)]: value the error, else the relative residual; rows
    without a time or without either value are left out (a failed solver has no point)."""
    points = []
    try:
        with open(path, newline="") as f:
            reader = csv.DictReader(f)
            missing = {"solver", "seconds", "error", "rel_residual"} - set(reader.fieldnames or [])
            if missing:
                sys.exit("plot: %s: no column %s (expected solver,seconds,error,rel_residual,iterations)"
                         % (path, ", ".join(sorted(missing))))
            for row in reader:
                secs, err, res = number(row["seconds"]), number(row["error"]), number(row["rel_residual"])
                if secs is None or (err is None and res is None):
                    continue
                points.append((row["solver"], secs, err if err is not None else res, err is not None))
    except OSError as e:
        sys.exit("plot: %s: %s" % (path, e.strerror))
    return points


def work_precision(ax, points, colours):
    """Error (or residual) against time, log-log, one labelled point per solver."""
    cycle = plt.rcParams["axes.prop_cycle"].by_key().get("color", ["C0"])
    extra = 0
    for name, secs, value, is_error in points:
        colour = colours.get(name)
        if colour is None:  # a solver without a history: the next colour of the cycle
            colour, extra = cycle[(len(colours) + extra) % len(cycle)], extra + 1
        ax.loglog([max(secs, 1e-7)], [max(value, 1e-16)], ls="", ms=7, color=colour,
                  marker="o" if is_error else "^", mfc=colour if is_error else "none")
        text = name if value > 1e-16 else name + " (%s 0)" % ("error" if is_error else "residual")
        ax.annotate(text, (max(secs, 1e-7), max(value, 1e-16)), xytext=(5, 4), textcoords="offset points",
                    fontsize=8, color=colour)
    kinds = {p[3] for p in points}
    if kinds == {True}:
        label = "relative error against the reference"
    elif kinds == {False}:
        label = "relative residual (no reference solution)"
    else:
        label = "relative error (open triangles: residual, no reference)"
    ax.set_ylabel(label)
    ax.set_xlabel("time to tolerance incl. set-up [s]")
    ax.set_title("work-precision", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    if not points:
        ax.text(0.5, 0.5, "no solver finished", transform=ax.transAxes, ha="center", color="gray")
    else:  # room for the labels on a log axis, also when every point is at one time or value
        xs = [max(p[1], 1e-7) for p in points]
        ys = [max(p[2], 1e-16) for p in points]
        ax.set_xlim(min(xs) / 2, max(xs) * 3)
        ax.set_ylim(min(ys) / 5, max(ys) * 5)


(path, png, *rest), summary = split_args(sys.argv[1:])
title = rest[0] if rest else ""
runs = {}
with open(path) as f:
    for row in csv.DictReader(f):
        r = runs.setdefault(row["solver"], ([], [], []))
        r[0].append(int(row["iteration"]))
        r[1].append(float(row["seconds"]))
        r[2].append(max(float(row["rel_residual"]), 1e-16))
points = read_summary(summary) if summary is not None else None

if points is None:
    fig, (ax_t, ax_i) = plt.subplots(1, 2, figsize=(12, 4.5))
else:
    fig, (ax_t, ax_i, ax_w) = plt.subplots(1, 3, figsize=(17, 4.5))
colours = {}
for name, (its, secs, res) in runs.items():
    line, = ax_t.semilogy(secs, res, label=name, marker="." if len(res) < 60 else None)
    ax_i.semilogy(its, res, label=name, marker="." if len(res) < 60 else None, color=line.get_color())
    colours[name] = line.get_color()
ax_t.set_xlabel("time incl. set-up [s]")
ax_i.set_xlabel("iteration (cycles for PMG)")
for ax in (ax_t, ax_i):
    ax.set_ylabel("relative residual")
    ax.grid(True, which="both", alpha=0.3)
    ax.axhline(1e-3, color="gray", lw=0.8, ls="--")
ax_i.legend()
if points is not None:
    work_precision(ax_w, points, colours)
fig.suptitle(title, fontsize=9)
fig.tight_layout()
# Through a link to its target; never over a device, FIFO or folder (a rename would replace it).
target = os.path.realpath(png)
if os.path.exists(target) and not os.path.isfile(target):
    sys.exit("plot: %s is not a regular file" % png)
tmp = target + ".tmp.png"
fig.savefig(tmp, dpi=110)
os.replace(tmp, target)
