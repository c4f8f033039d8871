#!/usr/bin/env python3
"""A Python estimator's refit with and without its old model kept alive, beside the bare core
call, alternated in blocks on one data set.

`fit` lets go of the estimator's old model before the core fits the new one
(`CoreModel._release`). "kept" holds a reference to the old model through the fit, as the
estimator did before; "released" is the estimator as it is; "core" is `linpose._linpose.fit`,
whose result is dropped at once. Prints each mode's median of its block medians (microseconds).

    python3 bench/refit.py DIR [--object O] --train-step S [--method linear] [--turns 30] [--calls 100]
"""
import argparse
import statistics
import time

import numpy as np

import linpose

ap = argparse.ArgumentParser()
ap.add_argument("data")
ap.add_argument("--object", type=int)
ap.add_argument("--train-step", type=float, required=True)
ap.add_argument("--method", default="linear", choices=["linear", "eigenspace", "refined"])
ap.add_argument("--turns", type=int, default=30)
ap.add_argument("--calls", type=int, default=100, help="fits per block")
a = ap.parse_args()

X, y, params, _ = linpose.read_dataset(a.data, a.object)
train = linpose.train_mask(y, params, a.train_step)
Xt, yt = np.ascontiguousarray(X[train]), np.ascontiguousarray(y[train])
y2 = yt.reshape(len(yt), -1)
h, w = X.shape[1:]
cls = {"linear": linpose.LinearPose, "eigenspace": linpose.EigenspacePose, "refined": linpose.RefinedPose}[a.method]
est = cls(params=params).fit(Xt, yt)
settings = est._settings()
held = []


def kept():
    held[:] = [est.model_]
    est.fit(Xt, yt)


modes = {
    "kept": kept,
    "released": lambda: est.fit(Xt, yt),
    "core": lambda: linpose._linpose.fit(a.method, settings, Xt.reshape(len(Xt), -1), h, w, y2, params, None),
}
got = {k: [] for k in modes}
names = list(modes)
for i in range(a.turns):
    for k in names[i % 3:] + names[:i % 3]:
        ts = []
        for _ in range(a.calls):
            t = time.perf_counter()
            modes[k]()
            ts.append(time.perf_counter() - t)
        got[k].append(statistics.median(ts))
        held.clear()
for k, v in got.items():
    print(f"{k}: {statistics.median(v) * 1e6:.1f} us (blocks {min(v) * 1e6:.1f}-{max(v) * 1e6:.1f})")
