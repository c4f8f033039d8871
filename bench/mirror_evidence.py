#!/usr/bin/env python3
"""How much a rendered object's views differ from the views half a turn away, and which views
two evaluations disagree on. For each view with a partner at the same elevation 180 degrees
round, its *mark*: the squared distance between the two images binned by 4 (the second look's
binning, docs/confidence.md) at unit energy, over what the 8-bit rounding alone puts between
two such images (the rounding's variance, 1 / (12 * 255^2) a pixel, over the 16 pixels of a
bin, summed over the bins and scaled to unit energy). A mark of 1 is evidence the size of the
rounding; the front and back of an object that differ by a small mark have small ones.

Given two `linpose eval --json` files of the same data, it also prints the marks of the unseen
views that are over 20 degrees off in the second and not in the first (docs/normalization.md:
the twin as given and with `--normalize`).

    python3 bench/mirror_evidence.py DIR [FIRST.json SECOND.json]   # the Python package's environment
"""
import json
import sys

import numpy as np

import linpose

GROSS = 20.0
BIN = 4


def binned(img):
    h, w = (img.shape[0] // BIN) * BIN, (img.shape[1] // BIN) * BIN
    return img[:h, :w].reshape(h // BIN, BIN, w // BIN, BIN).mean(axis=(1, 3)).ravel()


def main():
    if len(sys.argv) not in (2, 4):
        sys.exit(__doc__)
    X, y, params, _ = linpose.read_dataset(sys.argv[1])
    names = [p[0] for p in params]
    el, az = y[:, names.index("elevation")], y[:, names.index("azimuth")]
    key = lambda e, a: (round(float(e), 6), round(float(a) % 360, 6))
    index = {key(e, a): i for i, (e, a) in enumerate(zip(el, az))}
    bins = np.stack([binned(x.astype(np.float64) / 255.0) for x in X])
    norms = np.linalg.norm(bins, axis=1)
    rounding = 1.0 / (12 * 255**2 * BIN * BIN)
    mark = {}
    for (e, a), i in index.items():
        j = index.get(key(e, a + 180))
        if j is None:
            continue
        d = np.sum((bins[i] / norms[i] - bins[j] / norms[j]) ** 2)
        noise = bins.shape[1] * rounding * (1 / norms[i] ** 2 + 1 / norms[j] ** 2)
        mark[(e, a)] = d / noise
    m = np.array(list(mark.values()))
    print(f"{len(mark)} views with a partner half a turn away: mark median {np.median(m):.1f}, quartiles {np.percentile(m, 25):.1f} and {np.percentile(m, 75):.1f}, {np.sum(m < 10)} under 10")
    if len(sys.argv) == 4:
        runs = [json.load(open(path))["samples"] for path in sys.argv[2:]]
        gross = [{s["image"] for s in run if not s["seen"] and s["error_deg"] > GROSS} for run in runs]
        pose = {s["image"]: s["true"] for s in runs[1]}
        new, gone = gross[1] - gross[0], gross[0] - gross[1]
        nm = np.array([mark[k] for k in (key(*pose[n][:2]) for n in new) if k in mark])
        print(f"over {GROSS:g} degrees in the second only: {len(new)} ({len(nm)} with a partner), in the first only: {len(gone)}")
        if len(nm):
            print(f"  their marks: median {np.median(nm):.1f}, quartiles {np.percentile(nm, 25):.1f} and {np.percentile(nm, 75):.1f}, {np.sum(nm < 10)} under 10")


if __name__ == "__main__":
    main()
