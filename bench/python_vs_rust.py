#!/usr/bin/env python3
"""linpose from Python against the Rust library and the numpy peer, side by side in one run.

For each data set and method: the fit on the training views' 8-bit pixels in memory and the
predict of every view (8-bit images, one batch), medians of at least REPS runs and 0.3 s
(Python: REPS pairs and 0.6 s, below), from
Python (the installed `linpose` package, in this
process), from Rust (crates/linpose/examples/fit_predict_timing.rs, the same work through the
library) and from the peer (peer.py's in-process fit_s and predict_s; the refined method has no
peer, so it is set beside the peer's eigenspace). And a single image's predict, 2000 of them:
the estimator's median minus the Rust process's, and minus the bare core call's alternated
with it in this process (the binding's own cost per call: the first difference also holds how
fast each process runs the same library code). The Rust process predicts its single images in
the same order (each timed view followed by an untimed one half the set away), so that neither
side's timed query finds its neighbour's part of the tables in the cache. Decoding is not timed
anywhere.

Besides the separate Rust process, the estimator is timed against the bare core call it wraps
(`linpose._linpose.fit` / `Model.predict`, the library behind PyO3's argument conversion),
alternated call by call in one process: the difference is what the Python layer costs. Each figure is a
median over ROUNDS rounds that alternate the Rust process and the Python measurements; the
predicts' lowest and highest round follow the table (the spread of a shared machine).

  python_vs_rust.py [--coil DIR] [--reps 5] [--rounds 5] [--peer-python PY]
"""
import argparse, json, os, statistics, subprocess, sys, tempfile, time

import numpy as np

import linpose

here = os.path.dirname(os.path.abspath(__file__))
root = os.path.dirname(here)
ap = argparse.ArgumentParser()
ap.add_argument("--coil", default=os.path.join(root, "..", "shared", "datasets", "coil-20-proc"))
ap.add_argument("--reps", type=int, default=5)
ap.add_argument("--rounds", type=int, default=5)
ap.add_argument("--peer-python", default=os.path.join(root, "..", ".peer-venv", "bin", "python"))
ap.add_argument("--peer", default=os.path.join(root, "..", "shared", "peer", "peer.py"))
a = ap.parse_args()
subprocess.run(["cargo", "build", "--release", "-q", "-p", "linpose", "-p", "linpose-cli", "--example", "fit_predict_timing", "--bin", "linpose"], check=True, cwd=root)
timing = os.path.join(root, "target", "release", "examples", "fit_predict_timing")
cli = os.path.join(root, "target", "release", "linpose")
tmp = tempfile.mkdtemp(prefix="pyvr-")

sets = []
paper = os.path.join(tmp, "duck")
subprocess.run([cli, "synth", "--object", "duck", "--out", paper], check=True, capture_output=True)
sets.append(("rendered duck, 1760 views 160x120, step 9", paper, None, 9, paper))
if os.path.isdir(a.coil):
    subprocess.run([sys.executable, os.path.join(here, "coil2dir.py"), a.coil, tmp, "--objects", "1"], check=True, capture_output=True)
    sets.append(("COIL-20 obj1, 72 views 128x128, step 10", a.coil, 1, 10, os.path.join(tmp, "obj1")))

cls = {"linear": linpose.LinearPose, "eigenspace": linpose.EigenspacePose, "refined": linpose.RefinedPose}
med = statistics.median


def timed_pair(f, g, reps):
    """Median seconds of f and of g, called alternately (f, g, f, g, ...) for at least REPS
    pairs and 0.6 s, so that both see the same moments of the machine's load."""
    tf, tg, start = [], [], time.perf_counter()
    while len(tf) < reps or time.perf_counter() - start < 0.6:
        t = time.perf_counter(); f(); tf.append(time.perf_counter() - t)
        t = time.perf_counter(); g(); tg.append(time.perf_counter() - t)
    return med(tf), med(tg)


def py_times(X, y, params, train, method):
    """(fit, predict, one image) through the estimator, and (fit, predict) through the bare core
    call it wraps, alternated call by call."""
    est = cls[method](params=params)
    # The training views picked once, as the Rust side's training set is made before timing.
    Xt, yt = np.ascontiguousarray(X[train]), np.ascontiguousarray(y[train])
    yt2 = yt.reshape(len(yt), -1)
    settings = est._settings()
    h, w = X.shape[1:]
    core_fit = lambda: linpose._linpose.fit(method, settings, Xt.reshape(len(Xt), -1), h, w, yt2, params, None)
    est.fit(Xt, yt)
    X2 = X.reshape(len(X), -1)
    fit, cfit = timed_pair(lambda: est.fit(Xt, yt), core_fit, a.reps)
    pred, cpred = timed_pair(lambda: est.predict(X), lambda: est.model_.predict(X2), a.reps)
    # One image at a time: the estimator, and the bare core call alternated with it (the
    # binding's own overhead, in one process, apart from how fast the process runs the library),
    # each on views the other has not just seen (a view just searched is faster again: its
    # part of the tables is in the cache).
    one, cone = [], []
    for i in range(2000):
        q, q2 = X[i % len(X)][None], X2[(i + len(X) // 2) % len(X)][None]
        t = time.perf_counter(); est.predict(q); one.append(time.perf_counter() - t)
        t = time.perf_counter(); est.model_.predict(q2); cone.append(time.perf_counter() - t)
    return fit, pred, med(one), cfit, cpred, med(cone)


rows = []
for label, data, obj, step, peer_dir in sets:
    X, y, params, _ = linpose.read_dataset(data, obj)
    train = linpose.train_mask(y, params, step)
    peer = {}
    if os.path.exists(a.peer) and os.path.exists(a.peer_python):
        runs = []
        for _ in range(3):
            out = os.path.join(tmp, "p.json")
            subprocess.run([a.peer_python, a.peer, peer_dir, "--train-step", str(step), "--json", out], check=True, capture_output=True)
            runs.append(json.load(open(out)))
        peer = {m: (med(r[m]["fit_s"] for r in runs), med(r[m]["predict_s"] for r in runs)) for m in ("linear", "eigenspace")}
    for method in ("linear", "eigenspace", "refined"):
        rust_args = [timing, data, "--train-step", str(step), "--method", method, "--reps", str(a.reps)] + (["--object", str(obj)] if obj else [])
        rust, py = [], []
        # Rounds alternating the Rust process and the Python measurements, so both see the
        # machine's load drift alike; medians over the rounds.
        for _ in range(a.rounds):
            r = json.loads(subprocess.run(rust_args, check=True, capture_output=True, text=True).stdout)
            rust.append((r["fit_s"], r["predict_s"], r["predict_one_s"]))
            py.append(py_times(X, y, params, train, method))
        spread = (min(p[1] for p in py), max(p[1] for p in py), min(p[4] for p in py), max(p[4] for p in py), min(r[1] for r in rust), max(r[1] for r in rust))
        rust = tuple(med(r[j] for r in rust) for j in range(3))
        py = tuple(med(p[j] for p in py) for j in range(6))
        pm = peer.get(method) or peer.get("eigenspace")
        rows.append((label, method, py, rust, pm, spread))

print("| data | method | fit: Python / core call / Rust process | predict: Python / core call / Rust process | Python vs peer (fit, predict) | one image: Python - Rust process | one image: Python - core call |")
print("|---|---|---|---|---|---|---|")
for label, method, py, rust, pm, _ in rows:
    vs = f"{py[0] / pm[0]:.3f}x, {py[1] / pm[1]:.3f}x" + ("" if method != "refined" else " (peer eigenspace)") if pm else "no peer"
    print(
        f"| {label} | {method} | {py[0] * 1e3:.2f} / {py[3] * 1e3:.2f} / {rust[0] * 1e3:.2f} ms ({py[0] / py[3] - 1:+.1%}, {py[0] / rust[0] - 1:+.1%}) "
        f"| {py[1] * 1e3:.3f} / {py[4] * 1e3:.3f} / {rust[1] * 1e3:.3f} ms ({py[1] / py[4] - 1:+.1%}, {py[1] / rust[1] - 1:+.1%}) | {vs} | {(py[2] - rust[2]) * 1e6:.1f} us | {(py[2] - py[5]) * 1e6:.1f} us |"
    )

load = open("/proc/loadavg").read().split()[:3]
print(f"\nload average at the end: {' '.join(load)}; predict, the rounds' lowest - highest (ms): Python / core call / Rust process")
for label, method, _, _, _, sp in rows:
    print(f"  {label}, {method}: {sp[0] * 1e3:.3f}-{sp[1] * 1e3:.3f} / {sp[2] * 1e3:.3f}-{sp[3] * 1e3:.3f} / {sp[4] * 1e3:.3f}-{sp[5] * 1e3:.3f}")
