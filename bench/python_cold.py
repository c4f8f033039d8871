#!/usr/bin/env python3
"""What the Python process adds to a call into linpose, beside bench/python_vs_rust.py's totals.

1. Python code right after a call that streamed megabytes through the caches ("cold") against
   the same code at once again ("warm"): an empty function, `np.empty`, the core's
   single-image predict and the estimator's, each timed after a predict of the whole set
   (COIL-20 object 1, 72 views, linear model), medians of REPS.
2. The estimator's fit against the bare core fit it wraps, alternated: the Python time around
   the core (same data).
3. A batch predict (the rendered duck's 1760 views, linear, 8-bit) from the array
   `read_dataset` gives (numpy's own: huge pages for a large one) and from the same values in
   memory of 4 kB pages (an anonymous mapping advised MADV_NOHUGEPAGE), alternated.

  python bench/python_cold.py [--coil DIR] [--reps 2000]     # with the package installed
"""
import argparse, mmap, os, statistics, subprocess, sys, tempfile, time

import numpy as np

import linpose

here = os.path.dirname(os.path.abspath(__file__))
root = os.path.dirname(here)
ap = argparse.ArgumentParser()
ap.add_argument("--coil", default=os.path.join(root, "..", "shared", "datasets", "coil-20-proc"))
ap.add_argument("--reps", type=int, default=2000)
a = ap.parse_args()
pc, med = time.perf_counter, statistics.median
tmp = tempfile.mkdtemp(prefix="pycold-")
cli = os.path.join(root, "target", "release", "linpose")
subprocess.run(["cargo", "build", "--release", "-q", "-p", "linpose-cli", "--bin", "linpose"], check=True, cwd=root)

if os.path.isdir(a.coil):
    X, y, params, _ = linpose.read_dataset(a.coil, 1)
    label = "COIL-20 object 1, 72 views 128 x 128, every 10 degrees trained"
else:
    subprocess.run([cli, "synth", "--object", "duck", "--out", os.path.join(tmp, "c"), "--elevation", "32", "--azimuth", "0:355:5", "--size", "128x128"], check=True, capture_output=True)
    X, y, params, _ = linpose.read_dataset(os.path.join(tmp, "c"))
    label = "rendered duck, 72 views 128 x 128 (no COIL-20 here), every 10 degrees trained"
train = linpose.train_mask(y, params, 10)
Xt, yt = np.ascontiguousarray(X[train]), np.ascontiguousarray(y[train])
est = linpose.LinearPose(params=params).fit(Xt, yt)
core = est.model_
X2 = X.reshape(len(X), -1)
q3, q2 = X[3:4].copy(), X2[3:4].copy()


def empty():
    pass


print(f"1. {label}: cold (after a predict of all views) / warm (at once again), median us")
for name, f in (("empty function", empty), ("np.empty((1, 2))", lambda: np.empty((1, 2))), ("core predict, one image", lambda: core.predict(q2)), ("estimator predict, one image", lambda: est.predict(q3))):
    cold, warm = [], []
    for _ in range(a.reps):
        core.predict(X2)
        t0 = pc(); f(); t1 = pc(); f(); t2 = pc()
        cold.append(t1 - t0); warm.append(t2 - t1)
    print(f"   {name:30s} {med(cold) * 1e6:6.2f} / {med(warm) * 1e6:6.2f}")

settings = est._settings()
h, w = X.shape[1:]
core_fit = lambda: linpose._linpose.fit("linear", settings, Xt.reshape(len(Xt), -1), h, w, yt.reshape(len(yt), -1), params, None)
tf, tc = [], []
for _ in range(max(50, a.reps // 10)):
    t = pc(); est.fit(Xt, yt); tf.append(pc() - t)
    t = pc(); core_fit(); tc.append(pc() - t)
print(f"2. fit, alternated: estimator {med(tf) * 1e6:.1f} us, core {med(tc) * 1e6:.1f} us: {(med(tf) - med(tc)) * 1e6:.1f} us in Python")

duck = os.path.join(tmp, "duck")
subprocess.run([cli, "synth", "--object", "duck", "--out", duck], check=True, capture_output=True)
D, dy, dparams, _ = linpose.read_dataset(duck)
model = linpose.LinearPose(params=dparams).fit(D[linpose.train_mask(dy, dparams, 9)], dy[linpose.train_mask(dy, dparams, 9)]).model_
D2 = D.reshape(len(D), -1)
m = mmap.mmap(-1, D2.nbytes + 4096)
m.madvise(mmap.MADV_NOHUGEPAGE)
raw = np.frombuffer(m, np.uint8)
off = (-raw.ctypes.data) % 4096
small = raw[off:off + D2.nbytes].reshape(D2.shape)
small[...] = D2
ta, tb = [], []
for _ in range(200):
    t = pc(); model.predict(D2); ta.append(pc() - t)
    t = pc(); model.predict(small); tb.append(pc() - t)
print(f"3. rendered duck, 1760 views 160 x 120, linear, alternated: from read_dataset's array {med(ta) * 1e3:.3f} ms, from 4 kB pages {med(tb) * 1e3:.3f} ms")
