#!/usr/bin/env python3
"""Sweeps BoomerAMG settings on one system and tabulates iterations, set-up, solve and complexity.

Every setting runs as a named solver configuration of ONE `pmg compare` process (--solver-config):
the same matrix, the same MPI start-up (charged to no solver), the solvers one after another.

  /usr/bin/python3 tools/amg_sweep.py --pmg build/tools/pmg \
      --vary nodal=0,4 --vary strong_threshold=0.25,0.5,0.7 --vary relax_order=0,1 \
      -- --mesh models/homer.ele -p 3 --fix z --fix-fraction 0.05 --load gravity --tol 1e-6

By default each --vary list is swept one at a time around the base settings (the factory's
defaults, changed by --base key=value); --grid runs every combination instead. A --vary value
may set several keys at once with '+': --vary nodal=0,4+interp_vectors=rigid.
The table (markdown) goes to stdout and, with --out, to a file; rows are sorted by total time.
"""
import argparse
import itertools
import json
import os
import re
import subprocess
import sys
import tempfile


def parse_vary(text):
    key, _, values = text.partition("=")
    if not key or not values:
        raise SystemExit(f"--vary {text}: expected key=v1,v2,...")
    out = []
    for v in values.split(","):
        # "4+interp_vectors=rigid": key=4 plus other keys
        parts = v.split("+")
        setting = {key: parts[0]}
        for extra in parts[1:]:
            k, _, x = extra.partition("=")
            if not k or not x:
                raise SystemExit(f"--vary {text}: '{extra}' is not key=value")
            setting[k] = x
        out.append(setting)
    return key, out


def label(setting):
    return " ".join(f"{k}={v}" for k, v in setting.items()) or "(defaults)"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--pmg", default="build/tools/pmg", help="the pmg executable")
    ap.add_argument("--method", default="boomeramg-pcg", help="solver method the settings apply to")
    ap.add_argument("--base", action="append", default=[], help="key=value for every run")
    ap.add_argument("--vary", action="append", default=[], help="key=v1,v2,... (repeatable)")
    ap.add_argument("--grid", action="store_true", help="every combination instead of one at a time")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--out", help="also write the table (markdown) here")
    ap.add_argument("compare_args", nargs=argparse.REMAINDER, help="-- then pmg compare's system options")
    a = ap.parse_args()
    args = a.compare_args[1:] if a.compare_args[:1] == ["--"] else a.compare_args
    if not args:
        raise SystemExit("give the system after --, e.g. -- --mesh models/homer.ele -p 3 ...")
    base = {}
    for b in a.base:
        k, _, v = b.partition("=")
        if not k or not v:
            raise SystemExit(f"--base {b}: expected key=value")
        base[k] = v
    varies = [parse_vary(v) for v in a.vary]

    settings = [{}]
    if a.grid and varies:
        settings = []
        for combo in itertools.product(*[vals for _, vals in varies]):
            s = {}
            for part in combo:
                s.update(part)
            settings.append(s)
    else:
        for _, vals in varies:
            for v in vals:
                if v not in settings:
                    settings.append(v)
    configs = {}
    for s in settings:
        c = {"method": a.method}
        c.update(base)
        c.update(s)
        name = label(s)
        configs[name] = c

    with tempfile.TemporaryDirectory() as tmp:
        cfg = os.path.join(tmp, "configs.json")
        rep = os.path.join(tmp, "report.json")
        with open(cfg, "w") as f:
            json.dump(configs, f)
        cmd = [a.pmg, "compare", "--solver-config", cfg, "--json", rep, "--no-reference",
               "--threads", str(a.threads)] + args
        print("running:", " ".join(cmd), file=sys.stderr)
        proc = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        if not os.path.exists(rep):
            sys.stderr.write(proc.stdout)
            raise SystemExit(f"pmg compare failed (exit {proc.returncode})")
        with open(rep) as f:
            report = json.load(f)

    rows = []
    for s in report["solvers"]:
        m = re.search(r"(\d+) levels, grid complexity ([\d.]+), operator complexity ([\d.]+)", s.get("settings", ""))
        levels, gc, oc = (m.group(1), float(m.group(2)), float(m.group(3))) if m else ("-", float("nan"), float("nan"))
        total = s["setup_s"] + s["solve_s"]
        per_it = s["solve_s"] / s["iterations"] if s["iterations"] else float("nan")
        rows.append((total, s["name"], s["status"], s["iterations"], s["setup_s"], s["solve_s"], per_it, levels, gc, oc))
    rows.sort(key=lambda r: (r[2] != "converged", r[0]))
    sysd = report["system"]
    lines = [f"system: {sysd['description']}, {sysd['unknowns']} unknowns; {report['threads']} thread(s); "
             f"stop {report['stop']}; method {a.method}" + (f"; base {label(base)}" if base else ""),
             "",
             "| settings | status | iterations | set-up [s] | solve [s] | total [s] | per iteration [ms] | levels | grid c. | operator c. |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for total, name, status, its, su, so, pi, lv, gc, oc in rows:
        lines.append(f"| {name} | {status} | {its} | {su:.2f} | {so:.2f} | {total:.2f} | {1e3 * pi:.0f} | {lv} | {gc:.2f} | {oc:.2f} |")
    text = "\n".join(lines) + "\n"
    sys.stdout.write(text)
    if a.out:
        tmp = a.out + ".tmp"
        with open(tmp, "w") as f:
            f.write(text)
        os.replace(tmp, a.out)
    return 0 if all(r[2] == "converged" for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
