#!/usr/bin/env python3
"""COIL-20 object 1's linear fit (or another method's): the Rust library in its own process
(`examples/fit_predict_timing.rs`) against the bare core call from Python
(`linpose._linpose.fit`, the library behind PyO3's argument conversion), on one and on two
threads: what of `bench/python_vs_rust.py`'s fit gap lies in the call itself.

Each round runs the Rust process once (its median fit over 0.3 s), then the core call back to
back for 0.6 s, and reports the medians over the rounds; the figures for each thread count come
from a child process started with `RAYON_NUM_THREADS` set (rayon reads it once).

  fit_gap.py [--coil DIR] [--method linear] [--rounds 7] [--threads 1,2]
"""
import argparse, json, os, statistics, subprocess, sys, time

here = os.path.dirname(os.path.abspath(__file__))
root = os.path.dirname(here)
ap = argparse.ArgumentParser()
ap.add_argument("--coil", default=os.path.join(root, "..", "shared", "datasets", "coil-20-proc"))
ap.add_argument("--method", default="linear")
ap.add_argument("--rounds", type=int, default=7)
ap.add_argument("--threads", default="1,2")
ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
a = ap.parse_args()
timing = os.path.join(root, "target", "release", "examples", "fit_predict_timing")

if not a.child:
    if not os.path.isdir(a.coil):
        sys.exit(f"no COIL-20 at {a.coil} (--coil DIR)")
    subprocess.run(["cargo", "build", "--release", "-q", "-p", "linpose", "--example", "fit_predict_timing"], check=True, cwd=root)
    print(f"COIL-20 object 1, {a.method} fit, medians of {a.rounds} rounds (ms)")
    for t in a.threads.split(","):
        env = dict(os.environ, RAYON_NUM_THREADS=t)
        out = subprocess.run([sys.executable, __file__, "--child", "--coil", a.coil, "--method", a.method, "--rounds", str(a.rounds)], env=env, check=True, capture_output=True, text=True).stdout
        print(f"  {t} thread(s): {out.strip()}")
    load = open("/proc/loadavg").read().split()[:3]
    print(f"load average at the end: {' '.join(load)}")
    sys.exit(0)

import numpy as np

import linpose

med = statistics.median
X, y, params, _ = linpose.read_dataset(a.coil, 1)
train = linpose.train_mask(y, params, 10)
est = {"linear": linpose.LinearPose, "eigenspace": linpose.EigenspacePose, "refined": linpose.RefinedPose}[a.method](params=params)
Xt, yt = np.ascontiguousarray(X[train]), np.ascontiguousarray(y[train])
est.fit(Xt, yt)
h, w = X.shape[1:]
X2, yt2, settings = Xt.reshape(len(Xt), -1), yt.reshape(len(yt), -1), est._settings()
core = lambda: linpose._linpose.fit(a.method, settings, X2, h, w, yt2, params, None)
rust, py = [], []
for _ in range(a.rounds):
    r = subprocess.run([timing, a.coil, "--object", "1", "--train-step", "10", "--method", a.method], capture_output=True, text=True, check=True)
    rust.append(json.loads(r.stdout)["fit_s"])
    ts, start = [], time.perf_counter()
    while time.perf_counter() - start < 0.6:
        t = time.perf_counter()
        core()
        ts.append(time.perf_counter() - t)
    py.append(med(ts))
print(f"Rust process {med(rust) * 1e3:.3f}, core call {med(py) * 1e3:.3f} ({med(py) / med(rust) - 1:+.1%}); rounds {min(rust) * 1e3:.2f}-{max(rust) * 1e3:.2f} / {min(py) * 1e3:.2f}-{max(py) * 1e3:.2f}")
