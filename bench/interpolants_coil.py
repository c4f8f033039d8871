#!/usr/bin/env python3
"""Unseen error of the eigenspace on COIL-20 with other interpolants between training views.

The exploratory measurement behind the refined method's local cubic (BENCHMARKS.md, twenty-first
session): for every object, train step 10 (36 views), the plain eigenspace metric in L = 20
coordinates, the nearest of the 0.5-degree lattice, each interpolant through the 36 knots'
coordinates; images as given and binned by 4. Prints each object's unseen mean error (degrees)
and the means over the 20 objects. Needs numpy, scipy and Pillow (the peer's environment).

    python3 bench/interpolants_coil.py [--data ../shared/datasets/coil-20-proc]
"""
import argparse
import numpy as np
from PIL import Image
from scipy.interpolate import CubicHermiteSpline, CubicSpline, make_interp_spline

ap = argparse.ArgumentParser()
ap.add_argument("--data", default="../shared/datasets/coil-20-proc")
a = ap.parse_args()
LAT = np.arange(720) * 0.5
KNOTS = np.arange(37) * 10.0


def load(o, b):
    x = np.stack([np.array(Image.open(f"{a.data}/obj{o}__{k}.png")).astype(float) / 255 for k in range(72)])
    n, h, w = x.shape
    x = x.reshape(n, h // b, b, w // b, b).mean(axis=(2, 4)).reshape(n, -1)
    return x / np.linalg.norm(x, axis=1, keepdims=True)


def curves(z):
    n = z.shape[0]
    zz = np.vstack([z, z[:1]])
    herm = lambda m: CubicHermiteSpline(KNOTS, zz, np.vstack([m, m[:1]]))(LAT)
    central = (np.roll(z, -1, 0) - np.roll(z, 1, 0)) / 20.0
    f = np.fft.rfft(z, axis=0)
    f[-1] /= 2  # the Nyquist term split between +-k
    coef = np.full(f.shape[0], 2.0)
    coef[0] = 1
    e = np.exp(2j * np.pi * np.outer(LAT / 360.0, np.arange(f.shape[0])))
    t = LAT / 10.0
    i = np.floor(t).astype(int) % n
    u = (t - np.floor(t))[:, None]
    return {
        "spline": CubicSpline(KNOTS, zz, bc_type="periodic")(LAT),
        "catmull-rom": herm(central),
        "half-slopes": herm(0.5 * central),
        "linear": (1 - u) * z[i] + u * z[(i + 1) % n],
        "trigonometric": np.real((e * coef) @ f) / n,
        "quintic": make_interp_spline(KNOTS, zz, k=5, bc_type="periodic")(LAT),
    }


def run(o, b, l=20):
    x = load(o, b)
    tr, te, truth = x[0::2], x[1::2], np.arange(36) * 10.0 + 5
    mu = tr.mean(0)
    basis = np.linalg.svd(tr - mu, full_matrices=False)[2][:l]
    z, q = (tr - mu) @ basis.T, (te - mu) @ basis.T
    out = {}
    for name, c in curves(z).items():
        est = LAT[((q[:, None, :] - c[None, :, :]) ** 2).sum(-1).argmin(1)]
        out[name] = np.abs((est - truth + 180) % 360 - 180).mean()
    return out


total = {}
for o in range(1, 21):
    cells = []
    for b in (1, 4):
        r = run(o, b)
        for k, v in r.items():
            total[(b, k)] = total.get((b, k), 0.0) + v / 20
        cells.append(" ".join(f"{v:.3f}" for v in r.values()))
    print(f"obj{o:<3}", " | ".join(cells), flush=True)
names = list(curves(np.zeros((36, 1))).keys())
print("interpolants:", ", ".join(names))
for b in (1, 4):
    print(f"mean, binned by {b}:", " ".join(f"{k} {total[(b, k)]:.3f}" for k in names))
