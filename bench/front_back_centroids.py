#!/usr/bin/env python3
"""Where a rendered object's views half a turn apart sit in the frame: for every pair of views
at the same elevation and azimuths 180 degrees apart, the distance between their centroids,
weighted by each pixel's deviation from the (dark) background over the pixels at least one
gray level above it, as the normalisation stage finds an object on a dark background
(docs/normalization.md). Prints the pairs' median and largest distance, the three largest
pairs, and the least and the largest, over the elevations, of how far the centroid's column
moves over a turn.

    python3 bench/front_back_centroids.py DIR      # e.g. a folder of `linpose synth --object twin`
"""
import sys

import numpy as np

import linpose

X, y, params, _ = linpose.read_dataset(sys.argv[1])
names = [p[0] for p in params]
el, az = y[:, names.index("elevation")], y[:, names.index("azimuth")]
h, w = X.shape[1:]
ys, xs = np.mgrid[0:h, 0:w]
W = np.where(X >= 1, X, 0).astype(np.float64)
mass = W.sum(axis=(1, 2))
cent = np.stack([(W * xs).sum(axis=(1, 2)) / mass, (W * ys).sum(axis=(1, 2)) / mass], axis=1)
index = {(round(e, 6), round(a % 360, 6)): i for i, (e, a) in enumerate(zip(el, az))}
pairs = []
for (e, a), i in index.items():
    j = index.get((e, round((a + 180) % 360, 6)))
    if j is not None and a < 180:
        pairs.append((float(np.linalg.norm(cent[i] - cent[j])), e, a))
pairs.sort()
d = [p[0] for p in pairs]
print(f"{len(pairs)} pairs half a turn apart: median {np.median(d):.3f} px, largest {d[-1]:.3f} px")
for p in pairs[-3:]:
    print(f"  elevation {p[1]:g}, azimuths {p[2]:g} and {p[2] + 180:g}: {p[0]:.3f} px")
spread = [np.ptp(cent[el == e, 0]) for e in np.unique(el)]
print(f"the centroid's column over a turn spans {min(spread):.2f}-{max(spread):.2f} px (over the elevations)")
