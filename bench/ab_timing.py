#!/usr/bin/env python3
"""Two builds of `benches/fit_predict_timing` (say, a commit's and its parent's) side by side on
one data set: both started in `--serve` mode, then asked in turn (the order alternating) for a
block of fits or predicts of BLOCK seconds each, TURNS times; prints each build's median of its
block medians, their ratio, and the blocks' range. Both builds see the same stretches of a
shared machine's load, so the ratio holds where absolute times drift.

    git checkout A && cp "$(python3 -c 'import sys; sys.path.insert(0, "bench"); from bench_bin import bench_binary; print(bench_binary("fit_predict_timing"))')" /tmp/a
    git checkout B && ... && cp ... /tmp/b
    python3 bench/ab_timing.py /tmp/a /tmp/b DATA [--object O] --train-step S --method M --what fit|predict
"""
import argparse
import statistics

from block_server import Server

ap = argparse.ArgumentParser()
ap.add_argument("a")
ap.add_argument("b")
ap.add_argument("data")
ap.add_argument("--object")
ap.add_argument("--train-step", required=True)
ap.add_argument("--method", required=True)
ap.add_argument("--what", choices=["fit", "predict"], required=True)
ap.add_argument("--turns", type=int, default=21)
ap.add_argument("--block", type=float, default=0.2)
a = ap.parse_args()


def server(binary):
    return Server([binary, a.data, "--train-step", a.train_step, "--method", a.method, "--serve"] + (["--object", a.object] if a.object else []))


pa, pb = server(a.a), server(a.b)
ta, tb = [], []
for i in range(a.turns):
    for p, t in ((pa, ta), (pb, tb)) if i % 2 == 0 else ((pb, tb), (pa, ta)):
        t.append(p(f"{a.what} {a.block}"))
for p in (pa, pb):
    p.close()
ma, mb = statistics.median(ta), statistics.median(tb)
load = open("/proc/loadavg").read().split()[:3]
print(
    f"{a.method} {a.what}: A {ma * 1e3:.3f} ms, B {mb * 1e3:.3f} ms ({mb / ma - 1:+.1%}); "
    f"blocks {min(ta) * 1e3:.2f}-{max(ta) * 1e3:.2f} / {min(tb) * 1e3:.2f}-{max(tb) * 1e3:.2f} ms; load {' '.join(load)}"
)
