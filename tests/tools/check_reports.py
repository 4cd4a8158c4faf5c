"""pmg compare --json and pmg simulate --json: the reports hold the figures the tools print.

  /usr/bin/python3 tests/tools/check_reports.py PMG DATA_DIR
"""
import csv
import math
import os
import re
import sys
import tempfile

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tools"))
import pmgreport  # noqa: E402

pmg, data = sys.argv[1], sys.argv[2]
failures = []
passed = []


def check(cond, what):
    print(("ok   " if cond else "FAIL ") + what)
    (passed if cond else failures).append(what)


# compare: the system size and every solver's row, against the printed table.
p, r = pmgreport.run([pmg, "compare", "--grid", "6", "--solvers", "cg,block-jacobi-pcg,cholmod"])
check(p.returncode == 0 and r is not None, "compare exits 0 and writes a report")
size = re.search(r"size: +(\d+) unknowns, (\d+) nonzeros", p.stdout)
check(r["system"]["unknowns"] == int(size.group(1)) and r["system"]["nonzeros"] == int(size.group(2)),
      "compare: unknowns and nonzeros as printed")
check([s["name"] for s in r["solvers"]] == ["cg", "block-jacobi-pcg", "cholmod"], "compare: one entry per solver, in order")
for s in r["solvers"]:
    row = re.search(r"^%s +(\S+) +(\d+) +([0-9.]+) +([0-9.]+) " % re.escape(s["name"]), p.stdout, re.M)
    check(row is not None and row.group(1) == s["status"] and int(row.group(2)) == s["iterations"]
          and abs(float(row.group(4)) - s["solve_s"]) <= 1e-4 + 1e-3 * s["solve_s"],
          "compare: %s's status, iterations and solve time as printed" % s["name"])
    check(s["rel_residual"] is not None and s["rel_residual"] <= 1e-8, "compare: %s reached 1e-8" % s["name"])
    check(s["rel_error"] is not None and s["rel_error"] < 1e-6, "compare: %s's error against the known solution" % s["name"])

# compare: an FEM scene's load by stage, as printed, each within the load's total.
p, r = pmgreport.run([pmg, "compare", "--box", "3", "1", "1", "--refine", "1", "-p", "2", "--fix", "x",
                      "--load", "gravity", "--solvers", "mgpcg", "--no-reference"])
line = re.search(r"^load: (.*)$", p.stdout, re.M)
printed = {}
for segment in (line.group(1).split(";") if line else []):
    if segment.strip():
        name, value, _ = segment.strip().rsplit(" ", 2)  # "mesh (box) 0.004 s"
        printed[name] = float(value)
stages = {x["stage"]: x["seconds"] for x in r["load_stages"]} if r else {}
check(p.returncode == 0 and list(stages) == ["mesh (box)", "refinement", "degree hierarchy", "supports, clamp and inclusion",
                                             "loads and probe"], "compare: an FEM scene's load stages in the report")
check(all(abs(printed.get(k, -1) - v) <= 1e-3 for k, v in stages.items()) and sum(stages.values()) <= r["load_s"] + 1e-3,
      "compare: the load stages as printed, within the load's total")

# compare: a solver that fails is in the report with its message, and the exit code is 1.
p, r = pmgreport.run([pmg, "compare", "--matrix", os.path.join(data, "indefinite.mtx"), "--format", "csr",
                      "--solvers", "cholmod"])
check(p.returncode == 1 and r is not None and "not positive definite" in r["solvers"][0]["message"],
      "compare: a failed solver's message is in the report (exit 1)")

# bad input: no report, the tool's error line.
p, r = pmgreport.run([pmg, "compare", "--grid", "4", "--solvers", "gmres"])
check(p.returncode == 2 and r is None and "unknown method" in (pmgreport.error_line(p) or ""),
      "bad input: exit 2, no report, the error line")

# simulate: stages, steps, probe and energy against the printed report and steps.csv.
with tempfile.TemporaryDirectory() as d:
    p, r = pmgreport.run([pmg, "simulate", "--duration", "0.05", "-q", "-o", os.path.join(d, "out")])
    check(p.returncode == 0 and r is not None, "simulate exits 0 and writes a report")
    rows = list(csv.DictReader(open(os.path.join(d, "out", "steps.csv"))))
    check(r["steps"]["done"] == 5 == len(rows) - 1, "simulate: 5 steps in the report and in steps.csv")
    last = rows[-1]
    check(all(abs(float(last["probe_u" + c]) - r["probe"]["displacement_m"][i]) <= 1e-9 * (1 + abs(r["probe"]["displacement_m"][i]))
              for i, c in enumerate("xyz")), "simulate: the probe displacement is the last row's")
    check(abs(float(last["total_energy"]) - r["energy"]["final_J"]) <= 1e-9 * abs(r["energy"]["final_J"]),
          "simulate: the final energy is the last row's")
    stages = {s["stage"]: s for s in r["stages"]}
    for name in ("rotations", "finest matrix", "hierarchy update", "forces", "solve"):
        total = sum(float(x[name + "_s"]) for x in rows[1:])
        check(name in stages and math.isclose(stages[name]["total_s"], total, rel_tol=1e-6, abs_tol=1e-9),
              "simulate: stage '%s' is the sum of its steps.csv column" % name)
    check(r["mesh"]["unknowns"] == 12456 and r["mesh"]["degree"] == 3, "simulate: the mesh as printed")

# simulate: a failing step is in the report (exit 1).
p, r = pmgreport.run([pmg, "simulate", os.path.join(data, "scene_unsolvable.json"), "-q"])
check(p.returncode == 1 and r is not None and r["failure"]["step"] == 1 and "cg failed" in r["failure"]["message"],
      "simulate: a failed step is named in the report (exit 1)")

print("report checks: %d ok, %d wrong" % (len(passed), len(failures)))
sys.exit(1 if failures else 0)
