"""What the study scripts share: run `pmg simulate` / `pmg compare` with --json and read the report
(every figure the tool prints, with units in the key names) instead of parsing its text; write
files atomically (a temporary name, then a rename).

  import pmgreport
  proc, report = pmgreport.run(["build/tools/pmg", "compare", "-n", "8"])
  report["system"]["unknowns"], [s["solve_s"] for s in report["solvers"]]

A run that stops on bad input (exit 2) writes no report: `report` is then None and the tool's
`pmg: error: ...` line is in proc.stderr (error_line() returns it).
"""
import json
import os
import re
import subprocess
import tempfile


def run(cmd, timeout=None):
    """Runs cmd with --json added; returns (CompletedProcess, report dict or None).
    subprocess.TimeoutExpired propagates."""
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "report.json")
        proc = subprocess.run(list(cmd) + ["--json", path], capture_output=True, text=True,
                              timeout=timeout)
        report = None
        if os.path.exists(path):
            with open(path) as f:
                report = json.load(f)
    return proc, report


def error_line(proc):
    """The tool's own error message (`pmg: error: ...`) from a failed run, or None."""
    m = re.search(r"pmg: error: .*", proc.stderr + proc.stdout)
    return m.group(0).strip() if m else None


def atomic_write(path, text):
    d = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(dir=d, prefix=".tmp_")
    with os.fdopen(fd, "w") as f:
        f.write(text)
    os.replace(tmp, path)
