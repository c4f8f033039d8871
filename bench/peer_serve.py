#!/usr/bin/env python3
"""The numpy reference's fit and predict, one timed call per request, for `bench/python_vs_rust.py`
to alternate with linpose's calls one by one (so that both see the same moments of a shared
machine's load).

It loads the reference module from its file (`--peer`, the reference's own `peer.py`) and the
data set as the reference does, picks the training views by the reference's rule, and times
exactly the expressions the reference's own run times (`run_linear`, `run_eigenspace`: the fit
from the training rows and poses, the predict of every view with the poses decoded). Requests on
stdin, one a line: `fit linear SECONDS`, `predict linear SECONDS`, `fit eigenspace SECONDS`,
`predict eigenspace SECONDS`: the call repeated for that long (at least once), answered by a line
with the median seconds. It says `ready` once loaded; end of input ends it.

    python peer_serve.py --peer PEER.py DATA --train-step S
"""
import argparse
import importlib.util
import sys
import time

import numpy as np

ap = argparse.ArgumentParser()
ap.add_argument("data")
ap.add_argument("--peer", required=True)
ap.add_argument("--train-step", type=float, required=True)
a = ap.parse_args()

spec = importlib.util.spec_from_file_location("peer", a.peer)
peer = importlib.util.module_from_spec(spec)
spec.loader.exec_module(peer)

names, _, X, P = peer.load(a.data)
lo = P.min(0)
# The reference's training rule (its `main`).
r = np.mod(P - lo, a.train_step)
train = np.all(np.isclose(r, 0) | np.isclose(r, a.train_step), 1)
dim, dense = 20, 0.5  # the reference's defaults

models = {}


def fit_linear():
    models["linear"] = peer.Linear().fit(X[train], peer.encode(names, P[train]))


def predict_linear():
    peer.decode(names, models["linear"].predict(X))


def fit_eigenspace():
    models["eigenspace"] = peer.Eigenspace(dim, dense).fit(X[train], names, P[train])


def predict_eigenspace():
    models["eigenspace"].predict_pose(X)


calls = {
    "fit linear": fit_linear,
    "predict linear": predict_linear,
    "fit eigenspace": fit_eigenspace,
    "predict eigenspace": predict_eigenspace,
}
fit_linear()
fit_eigenspace()
print("ready", flush=True)
for line in sys.stdin:
    name, _, secs = line.strip().rpartition(" ")
    call = calls.get(name)
    if call is None:
        sys.exit(f"unknown request {line.strip()!r}: one of {', '.join(calls)}, then seconds")
    times, start = [], time.perf_counter()
    while not times or time.perf_counter() - start < float(secs):
        t = time.perf_counter()
        call()
        times.append(time.perf_counter() - t)
    print(sorted(times)[len(times) // 2], flush=True)
