"""Writes DIR/twisted.json: scenes/homer_twisted.json on models/homer.ele (absolute path), 10 steps
of 0.01 s, the default solver (matrix-free MGPCG to 1e-3 per step; the scene file names the
chapter's assembled PMG). Used by docs/results/kernels.sh and docs/results/step_update.sh:
    /usr/bin/python3 docs/results/twisted_homer_scene.py DIR"""
import json
import os
import sys

s = json.load(open("scenes/homer_twisted.json"))
s["mesh"]["file"] = os.path.abspath("models/homer.ele")
s["time"]["duration"] = 0.1
s["solver"] = {"method": "mgpcg", "tol": 1e-3}
json.dump(s, open(os.path.join(sys.argv[1], "twisted.json"), "w"))
