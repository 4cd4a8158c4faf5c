#!/usr/bin/env python3
"""The matrix-free products of two builds of bench_operator, alternating.

    /usr/bin/python3 docs/results/kernels_ab.py OLD_DIR [FILTER] [ROUNDS]

OLD_DIR holds the other build's bench_operator and its libpmg_fem.so (copied from that build's
build/bench/fem/ and build/fem/; the copy runs with LD_LIBRARY_PATH=OLD_DIR); the new one is
build/bench/fem/bench_operator. Each round runs the old build, then the new one, each with 10
repetitions of 0.1 s per benchmark (FILTER, default the double and float stiffness products at
p = 2 and 3 on 1 and 2 threads). Prints per benchmark the least and the median time [ms] over all
repetitions of each build: on a VM whose neighbours slow it down by tens of percent from minute to
minute, the least time is the one that other load touched least.
"""
import collections
import json
import os
import statistics
import subprocess
import sys
import tempfile

old_dir = sys.argv[1]
flt = sys.argv[2] if len(sys.argv) > 2 else "BM_MatrixFree/(2|3)/3/(8|4)/[12]/0"
rounds = int(sys.argv[3]) if len(sys.argv) > 3 else 3
builds = {
    "old": ([os.path.join(old_dir, "bench_operator")], {"LD_LIBRARY_PATH": old_dir}),
    "new": (["build/bench/fem/bench_operator"], {}),
}
times = collections.defaultdict(lambda: collections.defaultdict(list))
with tempfile.TemporaryDirectory() as tmp:
    out = os.path.join(tmp, "run.json")
    for _ in range(rounds):
        for who, (cmd, env) in builds.items():
            subprocess.run(cmd + ["--benchmark_filter=" + flt, "--benchmark_repetitions=10", "--benchmark_min_time=0.1",
                                  "--benchmark_out=" + out, "--benchmark_out_format=json"],
                           check=True, capture_output=True, env={**os.environ, **env})
            with open(out) as f:
                for b in json.load(f)["benchmarks"]:
                    if b.get("run_type") == "iteration":
                        times[b["run_name"]][who].append(b["real_time"])
print("# benchmark (p/kernel/precision/threads/dynamic): least and median time [ms] of %d x 10 repetitions" % rounds)
for name in sorted(times):
    short = name.replace("BM_MatrixFree/", "").replace("/real_time", "")
    cells = []
    for who in builds:
        t = times[name][who]
        cells.append("%s least %.3f median %.3f" % (who, min(t), statistics.median(t)))
    old, new = min(times[name]["old"]), min(times[name]["new"])
    print("%s: %s | old/new least %.3f" % (short, "  ".join(cells), old / new))
