#!/usr/bin/env python3
"""Issue 6, sixteenth session: two ideas for the turntable rows, tried in numpy before any Rust,
measured and dropped (BENCHMARKS.md, "Sixteenth session").

For each data set (linpose's format: poses.csv with an `azimuth` column, and the images; every
view's other parameters fixed), the training views are those at multiples of --train-step
degrees, the unseen views the rest. Brightness-normalised images, exact PCA (SVD) of the
training views, a periodic cubic spline through their coordinates sampled every 0.5 degrees,
nearest point: the eigenspace (as the peer's, but with exact PCA; the peer uses randomised PCA).

  lattice  the eigenspace's estimate, in --dim coordinates
  local    a local linear model of the pose on the coordinates, from the 4 training views
           nearest that estimate (minimum-norm exact fit through their centred coordinates,
           clipped to their poses' span, rounded to 0.5 degrees)
  average  the two estimates' circular mean, rounded to 0.5 degrees
  loo      leave-one-out on the training views (PCA, spline and local model refitted without
           each one in turn): lattice's and average's mean error on the held-out view, the
           only evidence a model could use to choose between them

and, with --dims, the eigenspace's unseen mean error with each number of coordinates.

  turntable_trial.py DIR... [--peer-cache DIR] [--train-step 10] [--dim 20] [--dims 12,16,17,18,20]

COIL-20: make the data sets with `bench/coil2dir.py COIL OUT` (symlinks, nothing copied).
Rendered turntables: `linpose synth --object duck --azimuth 0:359:5 --elevation 35:35:1 --out D`.
--peer-cache: beyond_compare.py's cache, whose peer/<key>-0.0.json give the peer's unseen error
(key: the folder's name, objN -> coilN).
"""
import argparse, csv, json, os, sys

import numpy as np
from PIL import Image
from scipy.interpolate import CubicSpline

ap = argparse.ArgumentParser()
ap.add_argument("data", nargs="+")
ap.add_argument("--peer-cache")
ap.add_argument("--train-step", type=float, default=10)
ap.add_argument("--dim", type=int, default=20)
ap.add_argument("--dims", default="")
a = ap.parse_args()


def load(d):
    with open(os.path.join(d, "poses.csv"), newline="") as f:
        head, *rows = list(csv.reader(f))
    if "azimuth" not in head:
        sys.exit(f"{d}/poses.csv: no azimuth column in {head}")
    col = head.index("azimuth")
    x = np.stack([np.asarray(Image.open(os.path.join(d, r[0])).convert("L"), dtype=np.float64).ravel() / 255 for r in rows])
    return x / np.linalg.norm(x, axis=1, keepdims=True), np.array([float(r[col]) for r in rows])


def wrap(v):
    return (v + 180) % 360 - 180


def fit(x, az, dim):
    mu = x.mean(0)
    v = np.linalg.svd(x - mu, full_matrices=False)[2][: min(dim, len(x) - 1)]
    order = np.argsort(az)
    return mu, v, az[order], (x[order] - mu) @ v.T


def lattice(knots, g, q):
    spl = CubicSpline(np.append(knots, knots[0] + 360), np.vstack([g, g[:1]]), bc_type="periodic")
    poses = np.arange(knots[0], knots[0] + 360, 0.5)
    return poses[((q[:, None, :] - spl(poses)[None]) ** 2).sum(-1).argmin(1)] % 360


def local(knots, g, q, t0, k=4):
    near = np.argsort(np.abs(wrap(knots - t0)))[:k]
    y, c = wrap(knots[near] - t0), g[near]
    cm, ym = c.mean(0), y.mean()
    cc = c - cm
    gram = cc @ cc.T
    w = cc.T @ np.linalg.solve(gram + 1e-6 * np.trace(gram) / k * np.eye(k), y - ym)
    return np.round((t0 + np.clip(ym + (q - cm) @ w, y.min(), y.max())) * 2) / 2 % 360


def average(t0, t1):
    return np.round((t0 + wrap(t1 - t0) / 2) * 2) / 2 % 360


def err(t, truth):
    return np.abs(wrap(t - truth))


def estimates(x, az, q, dim):
    mu, v, knots, g = fit(x, az, dim)
    y = (q - mu) @ v.T
    t0 = lattice(knots, g, y)
    t1 = np.array([local(knots, g, y[i], t0[i]) for i in range(len(y))])
    return t0, t1, average(t0, t1)


dims = [int(v) for v in a.dims.split(",") if v]
print(f"{'data':>14} {'peer':>6} {'lattice':>7} {'local':>6} {'average':>7}   loo: {'lattice':>7} {'average':>7}" + "".join(f" {'p' + str(d):>6}" for d in dims))
total = np.zeros(5)
for d in a.data:
    x, az = load(d)
    train = np.isclose(np.mod(az, a.train_step), 0) | np.isclose(np.mod(az, a.train_step), a.train_step)
    xt, at = x[train], az[train]
    un = [err(t, az[~train]).mean() for t in estimates(xt, at, x[~train], a.dim)]
    loo = np.zeros(2)
    for j in range(len(at)):
        keep = np.arange(len(at)) != j
        t0, _, t2 = estimates(xt[keep], at[keep], xt[j : j + 1], a.dim)
        loo += [err(t0, at[j])[0], err(t2, at[j])[0]]
    loo /= len(at)
    name = os.path.basename(os.path.normpath(d))
    peer = float("nan")
    if a.peer_cache:
        key = name.replace("obj", "coil") if name.startswith("obj") else name
        pj = os.path.join(a.peer_cache, "peer", f"{key}-0.0.json")
        if os.path.exists(pj):
            peer = json.load(open(pj))["eigenspace"]["unseen"]["mean_deg"]
    extra = "".join(f" {err(estimates(xt, at, x[~train], p)[0], az[~train]).mean():6.3f}" for p in dims)
    print(f"{name:>14} {peer:6.3f} {un[0]:7.3f} {un[1]:6.3f} {un[2]:7.3f}        {loo[0]:7.3f} {loo[1]:7.3f}{extra}")
    total += [*un, *loo]
print(f"{'sum':>14} {'':>6} {total[0]:7.2f} {total[1]:6.2f} {total[2]:7.2f}        {total[3]:7.2f} {total[4]:7.2f}")
