"""Medians of alternating old/new rounds from docs/results/step_update.sh, setup_forces.sh,
mixed_ratio_ab.sh or refined_job_ab.sh output.

    /usr/bin/python3 docs/results/ab_medians.py FILE [FILE ...]

Each file's "# batch" comment lines (if any) start a new batch. For every figure: the medians of the
old and new builds, their ratio old/new, and the range of the per-round ratios."""
import re
import statistics as st
import sys

FIELDS = {
    "t(1e-6) s": r"t6 ([\d.]+)", "one cycle ms": r"cycle ([\d.]+)", "twisted wall s": r"twisted wall ([\d.]+)",
    "hierarchy update ms": r"hier_ms ([\d.]+)", "twisted+frames wall s": r"twisted\+frames wall ([\d.]+)",
    "set-up s": r"setup ([\d.]+)", "smoother degree 3 s": r"smoother3 ([\d.]+)",
    "smoother degree 2 s": r"smoother2 ([\d.]+)", "lowest level s": r"lowest ([\d.]+)",
    "forces ms per step": r"forces_ms ([\d.]+)", "steps wall s": r"\| forces_ms [\d.]+ wall ([\d.]+)",
    "mixed total s": r"mixed its \d+ total ([\d.]+)", "mixed/mgpcg": r"\| ratio ([\d.]+)",
    "iterations": r"\| its (\d+) load", "load s": r" load ([\d.]+) setup", "solve s": r" solve ([\d.]+) t6",
    "load + t(1e-6) s": r" whole ([\d.]+)", "matrix-free degree 2 s": r" mf2 ([\d.]+)",
    "lowest level set-up s": r" lowsetup ([\d.]+)", "peak MB": r" peak ([\d.]+)",
}


def report(name, lines):
    rows = {"old": [], "new": []}
    for line in lines:
        m = re.match(r"\d+ (old|new) \|", line)
        if m:
            rows[m.group(1)].append(line)
    if not rows["old"]:
        return
    print(f"{name} ({len(rows['old'])} rounds)")
    for label, pattern in FIELDS.items():
        old = [re.search(pattern, l) for l in rows["old"]]
        new = [re.search(pattern, l) for l in rows["new"]]
        if not all(old) or not all(new):
            continue
        o = [float(x.group(1)) for x in old]
        n = [float(x.group(1)) for x in new]
        ratios = [a / b for a, b in zip(o, n) if b > 0]
        print(f"  {label:22s} old {st.median(o):.4g}  new {st.median(n):.4g}  ratio {st.median(o) / st.median(n):.2f}"
              f"  per round {min(ratios):.2f}-{max(ratios):.2f}")


for path in sys.argv[1:]:
    batch, lines = path, []
    for line in open(path):
        if line.startswith("# batch"):
            report(batch, lines)
            batch, lines = line[2:].strip(), []
        else:
            lines.append(line)
    report(batch, lines)
