#!/usr/bin/env python3
"""linpose from Python against the Rust library and the numpy peer, side by side in one run.

For each data set and method: the fit on the training views' 8-bit pixels in memory and the
predict of every view (8-bit images, one batch), from Python (the installed `linpose` package, in
this process), from Rust (crates/linpose/benches/fit_predict_timing.rs in `--serve` mode: the
same work through the library, in its own process) and from the peer (bench/peer_serve.py: the
expressions `peer.py` times, in its own process and virtual environment). Decoding is not timed
anywhere.

The sides take turns in blocks of BLOCK seconds (each call repeated back to back for that long,
warm, and the block's median kept), in a rotating order, each timed inside its own process (the
Rust process and the peer are asked for one block at a time through a pipe and wait idle
otherwise), so that every side sees the same stretches of a shared machine's load; each figure
is the median of TURNS blocks. After a block of the peer the next waits PEER_REST seconds: its
BLAS threads spin for a while after a call, and would take the cores from the next side's
block. Beside the estimator, the bare core call it wraps (`linpose._linpose.fit` /
`Model.predict`, the library behind PyO3's argument conversion) takes its turns too: the
difference is what the Python layer costs.

The peer is given two ways: as `peer.py` reports itself (its in-process `fit_s` and `predict_s`,
each a single call in a fresh process, the first of its kind there; medians of three runs), and
warm, in blocks like the others (bench/peer_serve.py). The refined method has no peer; its
ratios are to the peer's eigenspace of the same data.

One image: 2000 single-image predicts a side, in turns of ONE_BLOCK, each timed view followed
by an untimed one half the set away, so that no timed query finds its neighbour's part of the
tables in the cache: the estimator's median minus the Rust process's, and minus the core
call's.

  python_vs_rust.py [--coil DIR] [--turns 15] [--block 0.1] [--peer-python PY]
"""
import argparse, json, os, statistics, subprocess, sys, tempfile, time

import numpy as np

import linpose
from bench_bin import bench_binary
from block_server import Server

here = os.path.dirname(os.path.abspath(__file__))
root = os.path.dirname(here)
ap = argparse.ArgumentParser()
ap.add_argument("--coil", default=os.path.join(root, "..", "shared", "datasets", "coil-20-proc"))
ap.add_argument("--turns", type=int, default=15, help="blocks of each side per figure")
ap.add_argument("--block", type=float, default=0.1, help="least seconds of a block")
ap.add_argument("--peer-python", default=os.path.join(root, "..", ".peer-venv", "bin", "python"))
ap.add_argument("--peer", default=os.path.join(root, "..", "shared", "peer", "peer.py"))
a = ap.parse_args()
subprocess.run(["cargo", "build", "--release", "-q", "-p", "linpose-cli", "--bin", "linpose"], check=True, cwd=root)
timing = bench_binary("fit_predict_timing")
cli = os.path.join(root, "target", "release", "linpose")
tmp = tempfile.mkdtemp(prefix="pyvr-")
has_peer = os.path.exists(a.peer) and os.path.exists(a.peer_python)
# The peer's BLAS (OpenBLAS) threads spin after a call (about 2^28 cycles by default) before they
# sleep; the next side's call waits this long so as not to share the cores with them.
PEER_REST = 0.15
# Single-image predicts per block.
ONE_BLOCK = 200

sets = []
paper = os.path.join(tmp, "duck")
subprocess.run([cli, "synth", "--object", "duck", "--out", paper], check=True, capture_output=True)
sets.append(("rendered duck, 1760 views 160x120, step 9", paper, None, 9, paper))
if os.path.isdir(a.coil):
    subprocess.run([sys.executable, os.path.join(here, "coil2dir.py"), a.coil, tmp, "--objects", "1"], check=True, capture_output=True)
    sets.append(("COIL-20 obj1, 72 views 128x128, step 10", a.coil, 1, 10, os.path.join(tmp, "obj1")))

cls = {"linear": linpose.LinearPose, "eigenspace": linpose.EigenspacePose, "refined": linpose.RefinedPose}
med = statistics.median


def block(f):
    """Median seconds of f called back to back for a block (at least once)."""
    ts, start = [], time.perf_counter()
    while not ts or time.perf_counter() - start < a.block:
        t = time.perf_counter()
        f()
        ts.append(time.perf_counter() - t)
    return med(ts)


def turns(sides, n=None):
    """Each side's median over its blocks, the sides taking turns (the order rotating by one
    each turn) for TURNS turns."""
    names = list(sides)
    got = {k: [] for k in names}
    for i in range(n or a.turns):
        for k in names[i % len(names):] + names[:i % len(names)]:
            got[k].append(sides[k](i))
            if k == "peer":
                time.sleep(PEER_REST)
    return {k: med(v) for k, v in got.items()}


def peer_reported(peer_dir, step):
    """peer.py's own fit_s and predict_s (one call each in a fresh process, as it times them),
    medians of three runs."""
    runs = []
    for _ in range(3):
        out = os.path.join(tmp, "p.json")
        subprocess.run([a.peer_python, a.peer, peer_dir, "--train-step", str(step), "--json", out], check=True, capture_output=True)
        runs.append(json.load(open(out)))
    return {m: (med(r[m]["fit_s"] for r in runs), med(r[m]["predict_s"] for r in runs)) for m in ("linear", "eigenspace")}


rows = []
for label, data, obj, step, peer_dir in sets:
    X, y, params, _ = linpose.read_dataset(data, obj)
    train = linpose.train_mask(y, params, step)
    # The training views picked once, as the Rust side's training set is made before timing.
    Xt, yt = np.ascontiguousarray(X[train]), np.ascontiguousarray(y[train])
    yt2 = yt.reshape(len(yt), -1)
    h, w = X.shape[1:]
    X2 = X.reshape(len(X), -1)
    # peer.py's own runs first: the warm peer's process loads the images as it starts.
    reported = peer_reported(peer_dir, step) if has_peer else {}
    peer = Server([a.peer_python, os.path.join(here, "peer_serve.py"), "--peer", a.peer, peer_dir, "--train-step", str(step)]) if has_peer else None
    warm = {}
    for method in ("linear", "eigenspace", "refined"):
        rust = Server([timing, data, "--train-step", str(step), "--method", method, "--serve"] + (["--object", str(obj)] if obj else []))
        est = cls[method](params=params)
        settings = est._settings()
        est.fit(Xt, yt)
        core_fit = lambda: linpose._linpose.fit(method, settings, Xt.reshape(len(Xt), -1), h, w, yt2, params, None)
        sides = {"rust": lambda i: rust(f"fit {a.block}"), "python": lambda i: block(lambda: est.fit(Xt, yt)), "core": lambda i: block(core_fit)}
        if peer and method != "refined":
            sides["peer"] = lambda i: peer(f"fit {method} {a.block}")
        fit = turns(sides)
        sides = {"rust": lambda i: rust(f"predict {a.block}"), "python": lambda i: block(lambda: est.predict(X)), "core": lambda i: block(lambda: est.model_.predict(X2))}
        if peer and method != "refined":
            sides["peer"] = lambda i: peer(f"predict {method} {a.block}")
        pred = turns(sides)
        if "peer" in fit:
            warm[method] = (fit["peer"], pred["peer"])

        half = len(X) // 2

        def singles(first, f):
            """Median seconds of f on views first.., each followed by an untimed f on the view
            half the set away (as the Rust process does)."""
            ts = []
            for i in range(first, first + ONE_BLOCK):
                t = time.perf_counter()
                f(i % len(X))
                ts.append(time.perf_counter() - t)
                f((i + half) % len(X))
            return med(ts)

        sides = {
            "rust": lambda i: rust(f"one {i * ONE_BLOCK} {ONE_BLOCK}"),
            "python": lambda i: singles(i * ONE_BLOCK, lambda j: est.predict(X[j][None])),
            "core": lambda i: singles(i * ONE_BLOCK, lambda j: est.model_.predict(X2[j][None])),
        }
        one = turns(sides, 2000 // ONE_BLOCK)
        rust.close()
        rows.append((label, method, fit, pred, one, reported.get(method) or reported.get("eigenspace"), warm.get(method) or warm.get("eigenspace")))
    if peer:
        peer.close()

print("| data | method | fit: Python / core call / Rust process | predict: Python / core call / Rust process | Python vs peer as it reports itself (fit, predict) | Python vs peer warm | one image: Python - Rust process | one image: Python - core call |")
print("|---|---|---|---|---|---|---|---|")
for label, method, fit, pred, one, rep, warm in rows:
    note = "" if method != "refined" else " (peer eigenspace)"
    vs = [f"{fit['python'] / pm[0]:.3f}x, {pred['python'] / pm[1]:.3f}x{note}" if pm else "no peer" for pm in (rep, warm)]
    cells = []
    for t, digits in ((fit, 2), (pred, 3)):
        cells.append(
            f"{t['python'] * 1e3:.{digits}f} / {t['core'] * 1e3:.{digits}f} / {t['rust'] * 1e3:.{digits}f} ms "
            f"({t['python'] / t['core'] - 1:+.1%}, {t['python'] / t['rust'] - 1:+.1%})"
        )
    print(f"| {label} | {method} | {cells[0]} | {cells[1]} | {vs[0]} | {vs[1]} | {(one['python'] - one['rust']) * 1e6:.1f} us | {(one['python'] - one['core']) * 1e6:.1f} us |")

load = open("/proc/loadavg").read().split()[:3]
print(f"\nload average at the end: {' '.join(load)}")
