#!/usr/bin/env python3
"""Views not registered like the training views, and how many of their gross errors are flagged.

For each rendered object: `linpose synth` renders the paper's grid registered (R) and moved by up
to 8 pixels and scaled by 0.9-1.1 (G: `--jitter 8,0.1,0`, jitter seed 1). The eigenspace and the
refined method are trained on R every 9 degrees, without normalisation, and evaluated on the
unseen views of G. Prints per object and method the gross errors (over 20 degrees), how many of
them are flagged (confidence under the default threshold), the views flagged and the mean error.

    python3 bench/unregistered_flags.py [--linpose BIN] [--objects duck,pot,cap,twin,column]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"failed: {' '.join(cmd)}\n{r.stderr}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--linpose", default="target/release/linpose")
    ap.add_argument("--objects", default="duck,pot,cap,twin,column")
    a = ap.parse_args()
    b = os.path.abspath(a.linpose)
    print("| object | method | gross errors | gross errors flagged | views flagged | unseen mean error |")
    print("|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as t:
        for o in a.objects.split(","):
            run([b, "synth", "--object", o, "--out", f"{t}/{o}_R"])
            run([b, "synth", "--object", o, "--out", f"{t}/{o}_G", "--jitter", "8,0.1,0", "--jitter-seed", "1"])
            for m in ["eigenspace", "refined"]:
                run([b, "train", "--data", f"{t}/{o}_R", "--train-step", "9", "--method", m, "--out", f"{t}/m.st"])
                run([b, "eval", "--model", f"{t}/m.st", "--data", f"{t}/{o}_G", "--json", f"{t}/ev.json"])
                s = [x for x in json.load(open(f"{t}/ev.json"))["samples"] if not x["seen"]]
                gross = [x for x in s if x["error_deg"] > 20]
                flagged = sum(x["flagged"] for x in s)
                caught = sum(x["flagged"] for x in gross)
                pct = lambda k, n: f"{100 * k / n:.1f}%" if n else "-"
                mean = sum(x["error_deg"] for x in s) / len(s)
                print(f"| {o} | {m} | {len(gross)} of {len(s)} ({pct(len(gross), len(s))}) | {caught} ({pct(caught, len(gross))}) | {flagged} ({pct(flagged, len(s))}) | {mean:.2f} |", flush=True)


if __name__ == "__main__":
    main()
