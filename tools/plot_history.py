"""Residual-against-time and residual-against-iterations plots from a pmg compare history CSV
(solver,iteration,seconds,rel_residual), like the seed's Figs. 2.30 and 2.32.
Usage: /usr/bin/python3 plot_history.py history.csv out.png [title]"""
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

path, png = sys.argv[1], sys.argv[2]
title = sys.argv[3] if len(sys.argv) > 3 else ""
runs = {}
with open(path) as f:
    for row in csv.DictReader(f):
        r = runs.setdefault(row["solver"], ([], [], []))
        r[0].append(int(row["iteration"]))
        r[1].append(float(row["seconds"]))
        r[2].append(max(float(row["rel_residual"]), 1e-16))

fig, (ax_t, ax_i) = plt.subplots(1, 2, figsize=(12, 4.5))
for name, (its, secs, res) in runs.items():
    ax_t.semilogy(secs, res, label=name, marker="." if len(res) < 60 else None)
    ax_i.semilogy(its, res, label=name, marker="." if len(res) < 60 else None)
ax_t.set_xlabel("time incl. set-up [s]")
ax_i.set_xlabel("iteration (cycles for PMG)")
for ax in (ax_t, ax_i):
    ax.set_ylabel("relative residual")
    ax.grid(True, which="both", alpha=0.3)
    ax.axhline(1e-3, color="gray", lw=0.8, ls="--")
ax_i.legend()
fig.suptitle(title, fontsize=9)
fig.tight_layout()
# Through a link to its target; never over a device, FIFO or folder (a rename would replace it).
target = os.path.realpath(png)
if os.path.exists(target) and not os.path.isfile(target):
    sys.exit("plot: %s is not a regular file" % png)
tmp = target + ".tmp.png"
fig.savefig(tmp, dpi=110)
os.replace(tmp, target)
