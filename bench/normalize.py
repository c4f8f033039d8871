#!/usr/bin/env python3
"""Normalisation against registered training (issue 33's protocol), whole commands.

For each rendered object: `linpose synth` renders the registered views (R), the same views
shifted by up to 8 pixels and scaled by 0.9-1.1 (G: `--jitter 8,0.1,0`) and exposed 0.8-1.2 times
(E: `--jitter 0,0,0.2`), jitter seed 1. Each method is trained on R every 9 degrees, as it is and
with `--normalize`, and evaluated on the unseen views of R, G and E. Prints the unseen mean
errors and checks the bars: with normalisation, G and E at most 1.5 x R + 0.1 degrees, and
normalisation costing at most 10% on R. With --coil DIR, also every COIL-20 object (trained every
10 degrees) with and without --normalize, the mean of the per-object unseen means.

    python3 bench/normalize.py [--linpose BIN] [--objects duck,pot,cap,twin,column] [--coil DIR]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

METHODS = ["linear", "eigenspace", "refined"]


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"failed: {' '.join(cmd)}\n{r.stderr}")
    return r


def unseen(b, model, data, out, extra=()):
    run([b, "eval", "--model", model, "--data", data, "--json", out, "--top", "1", *extra])
    r = json.load(open(out))
    return (r["unseen"] or r["all"])["mean_deg"], len(r.get("rejected", [])), r["n_eval"] + len(r.get("rejected", []))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--linpose", default="target/release/linpose")
    ap.add_argument("--objects", default="duck,pot,cap,twin,column")
    ap.add_argument("--coil", default=None)
    a = ap.parse_args()
    b = os.path.abspath(a.linpose)
    failures = 0
    with tempfile.TemporaryDirectory() as t:
        print("| object | method | R | R, normalised | G | G, normalised | E | E, normalised | refused (G) | bars |")
        print("|---|---|---|---|---|---|---|---|---|---|")
        for o in a.objects.split(","):
            sets = {"R": [], "G": ["--jitter", "8,0.1,0", "--jitter-seed", "1"], "E": ["--jitter", "0,0,0.2", "--jitter-seed", "1"]}
            for k, extra in sets.items():
                run([b, "synth", "--object", o, "--out", f"{t}/{o}_{k}", *extra])
            for m in METHODS:
                e = {}
                for n, flag in (("plain", []), ("norm", ["--normalize"])):
                    model = f"{t}/{o}_{m}_{n}.st"
                    run([b, "train", "--data", f"{t}/{o}_R", "--train-step", "9", "--method", m, *flag, "--out", model])
                    for k in sets:
                        e[n, k] = unseen(b, model, f"{t}/{o}_{k}", f"{t}/ev.json")
                reg = e["norm", "R"][0]
                ok_g = e["norm", "G"][0] <= 1.5 * reg + 0.1
                ok_e = e["norm", "E"][0] <= 1.5 * reg + 0.1
                ok_r = reg <= 1.1 * e["plain", "R"][0]
                bars = "ok" if ok_g and ok_e and ok_r else "FAIL: " + ", ".join(w for w, ok in (("G", ok_g), ("E", ok_e), ("cost on R", ok_r)) if not ok)
                failures += bars != "ok"
                cells = " | ".join(f"{e[n, k][0]:.3f}" for k in sets for n in ("plain", "norm"))
                print(f"| {o} | {m} | {cells} | {e['norm', 'G'][1]} of {e['norm', 'G'][2]} | {bars} |", flush=True)
        if a.coil:
            print("\n| COIL-20 | method | unseen mean, as given | with --normalize | ratio |")
            print("|---|---|---|---|---|")
            for m in METHODS:
                s = {"plain": [], "norm": []}
                for obj in range(1, 21):
                    for n, flag in (("plain", []), ("norm", ["--normalize"])):
                        model = f"{t}/coil_{n}.st"
                        run([b, "train", "--data", a.coil, "--object", str(obj), "--train-step", "10", "--method", m, *flag, "--out", model])
                        s[n].append(unseen(b, model, a.coil, f"{t}/ev.json", ["--object", str(obj)])[0])
                p, q = sum(s["plain"]) / 20, sum(s["norm"]) / 20
                print(f"| 20 objects | {m} | {p:.3f} | {q:.3f} | {q / p:.3f} |", flush=True)
    print(f"\n{failures} rows miss a bar" if failures else "\nevery row meets the bars")


if __name__ == "__main__":
    main()
