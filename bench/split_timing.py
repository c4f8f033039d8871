#!/usr/bin/env python3
"""From how many query pixels a batch of 8-bit images is worth splitting across threads.

Alternates, in ROUNDS rounds, three runs of crates/linpose/benches/split_timing.rs on one data
set: every batch split across rayon's threads (LINPOSE_SPLIT_FROM_PIXELS=0, the behaviour before
the threshold), every batch whole on the calling thread (--whole), and the library as built (the
threshold of crates/linpose/src/model/split.rs). Prints, per method and batch size, the median
over the rounds of each run's median predict time. With --gap MS every run sleeps MS
milliseconds before each timed predict (a caller waiting for its next frame: the pool's workers
fall asleep in between).

  python3 bench/split_timing.py [DIR] [--object 1] [--train-step 10] [--rounds 5] [--sizes 8,16,36,72,144,288] [--gap MS]
"""
import argparse, json, os, statistics, subprocess
from bench_bin import bench_binary

here = os.path.dirname(os.path.abspath(__file__))
root = os.path.dirname(here)
ap = argparse.ArgumentParser()
ap.add_argument("data", nargs="?", default=os.path.join(root, "..", "shared", "datasets", "coil-20-proc"))
ap.add_argument("--object", default="1")
ap.add_argument("--train-step", default="10")
ap.add_argument("--rounds", type=int, default=5)
ap.add_argument("--sizes", default="8,16,36,72,144,288")
ap.add_argument("--gap", default="0", help="milliseconds the caller sleeps before each timed predict")
a = ap.parse_args()
exe = bench_binary("split_timing")
base = [exe, a.data, "--train-step", a.train_step, "--sizes", a.sizes, "--gap", a.gap] + (["--object", a.object] if a.object else [])
runs = {"split": (base, {"LINPOSE_SPLIT_FROM_PIXELS": "0"}), "whole": (base + ["--whole"], {}), "library": (base, {})}
got = {k: [] for k in runs}
for _ in range(a.rounds):
    for k, (cmd, env) in runs.items():
        out = subprocess.run(cmd, check=True, capture_output=True, text=True, env={**os.environ, **env}).stdout
        got[k].append(json.loads(out))
load = open("/proc/loadavg").read().split()[:3]
print(f"medians of {a.rounds} rounds, gap {a.gap} ms, load average {' '.join(load)} at the end")
print("| method | images | split ms | whole ms | library ms | whole / split |")
print("|---|---|---|---|---|---|")
for method in got["split"][0]:
    for n in got["split"][0][method]:
        med = {k: statistics.median(r[method][n] for r in v) for k, v in got.items()}
        print(f"| {method} | {n} | {med['split'] * 1e3:.4f} | {med['whole'] * 1e3:.4f} | {med['library'] * 1e3:.4f} | {med['whole'] / med['split']:.2f} |")
