#!/usr/bin/env python3
"""Pose from appearance on a COIL-style turntable set, from Python.

    python docs/examples/coil_pose.py COIL_DIR [--object 1] [--out error.png]

COIL_DIR holds images named objO__K.png (view K of object O, 72 views 5 degrees apart, as in
COIL-20). The script loads them with Pillow, trains linpose's three methods on every 10 degrees,
estimates the 36 views between, plots each method's error against azimuth, and tunes the
refined method's binning with scikit-learn's GridSearchCV.
"""
import argparse
import glob
import os
import re

import matplotlib

matplotlib.use("Agg")  # write the figure to a file; no window needed
import matplotlib.pyplot as plt
import numpy as np
from PIL import Image
from sklearn.model_selection import GridSearchCV, KFold

import linpose

ap = argparse.ArgumentParser()
ap.add_argument("coil_dir")
ap.add_argument("--object", type=int, default=1)
ap.add_argument("--out", default="error.png")
a = ap.parse_args()

# 1. Images and poses as numpy arrays: (n, h, w) uint8 and azimuths in degrees.
files = sorted(
    glob.glob(os.path.join(a.coil_dir, f"obj{a.object}__*.png")),
    key=lambda f: int(re.search(r"__(\d+)\.png$", f).group(1)),
)
views = np.array([int(re.search(r"__(\d+)\.png$", f).group(1)) for f in files])
X = np.stack([np.asarray(Image.open(f).convert("L")) for f in files])  # or cv2.imread(f, cv2.IMREAD_GRAYSCALE)
azimuth = 5.0 * views  # COIL-20: 72 views, 5 degrees apart
print(f"{len(X)} images of {X.shape[2]}x{X.shape[1]}")

# 2. The paper's protocol: train on every 10 degrees, estimate the views between.
train = linpose.train_mask(azimuth, ["azimuth"], 10)
params = [("azimuth", 360)]  # circular, period 360 (the default for a parameter named azimuth)

fig, ax = plt.subplots(figsize=(7, 3.5))
for est in (linpose.LinearPose(params=params), linpose.EigenspacePose(params=params), linpose.RefinedPose(params=params)):
    est.fit(X[train], azimuth[train])
    pred = est.predict(X)
    err = linpose.pose_error(azimuth, pred, params)
    print(f"{type(est).__name__:15s} unseen mean error {err[~train].mean():.2f} degrees (score {est.score(X[~train], azimuth[~train]):.2f})")
    ax.plot(azimuth[~train], err[~train], "o-", ms=3, label=type(est).__name__)
ax.set_xlabel("azimuth (degrees)")
ax.set_ylabel("error (degrees)")
ax.set_title(f"COIL object {a.object}: unseen views")
ax.legend()
fig.tight_layout()
fig.savefig(a.out, dpi=120)
print(f"wrote {a.out}")

# 3. A grid search over a parameter: the refined method's binning, scored by minus the mean pose
# error on held-out training views (three folds of the training set).
search = GridSearchCV(linpose.RefinedPose(params=params), {"bin": [1, 2, 4]}, cv=KFold(3, shuffle=True, random_state=0))
search.fit(X[train], azimuth[train])
best = search.best_estimator_
print(f"GridSearchCV: bin={search.best_params_['bin']} (held-out mean error {-search.best_score_:.2f} degrees); "
      f"unseen mean error {-best.score(X[~train], azimuth[~train]):.2f} degrees")

# 4. The model file is the command line's: `linpose predict --model refined.safetensors IMAGE`.
best.save("refined.safetensors")
