#!/usr/bin/env python3
"""The real-data check of the normalisation stage as `train` chooses it: every COIL-20 object
trained every 10 degrees with no normalisation flag, each method; the mean of the 20 objects'
unseen means is at most 0.25 degrees (refined), 0.40 (eigenspace) and 1.2 (linear). Also: every
COIL-20 view is accepted by the stage (`train --normalize` on all 72 views of each object).

    python3 bench/coil_normalize_check.py COIL_DIR [--linpose target/release/linpose]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

BARS = {"refined": 0.25, "eigenspace": 0.40, "linear": 1.2}

ap = argparse.ArgumentParser()
ap.add_argument("coil")
ap.add_argument("--linpose", default="target/release/linpose")
a = ap.parse_args()
failed = []
with tempfile.TemporaryDirectory() as t:
    def run(*args):
        r = subprocess.run([a.linpose, *args], capture_output=True, text=True)
        if r.returncode:
            sys.exit(f"failed: linpose {' '.join(args)}\n{r.stderr}")

    for obj in range(1, 21):
        run("train", "--data", a.coil, "--object", str(obj), "--normalize", "--out", os.path.join(t, "all.st"))
    print("ok   every COIL-20 view accepted by the stage (20 objects, 72 views each)")
    for method, bar in BARS.items():
        errs = []
        for obj in range(1, 21):
            model, ev = os.path.join(t, "m.st"), os.path.join(t, "e.json")
            run("train", "--data", a.coil, "--object", str(obj), "--train-step", "10", "--method", method, "--out", model)
            run("eval", "--model", model, "--data", a.coil, "--object", str(obj), "--json", ev)
            errs.append(json.load(open(ev))["unseen"]["mean_deg"])
        mean = sum(errs) / len(errs)
        ok = mean <= bar + 1e-9
        print(f"{'ok  ' if ok else 'FAIL'} {method}, default train: unseen mean over the 20 objects {mean:.4f} (<= {bar})")
        if not ok:
            failed.append(method)
sys.exit(1 if failed else 0)
