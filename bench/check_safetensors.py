#!/usr/bin/env python3
"""Checks that a linpose linear model file is usable from numpy alone: loads it with
`safetensors.numpy.load_file`, estimates the pose of images with `weights @ x + bias`, and
compares with `linpose predict --json` on the same images.

  check_safetensors.py MODEL IMAGE... [--linpose BIN] [--tol DEG]
"""
import argparse, json, os, subprocess, sys
import numpy as np
from PIL import Image
from safetensors.numpy import load_file
from safetensors import safe_open

root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ap = argparse.ArgumentParser()
ap.add_argument("model")
ap.add_argument("images", nargs="+")
ap.add_argument("--linpose", default=os.path.join(root, "target", "release", "linpose"))
ap.add_argument("--tol", type=float, default=1e-3)
a = ap.parse_args()

t = load_file(a.model)
with safe_open(a.model, "np") as f:
    meta = json.loads(f.metadata()["linpose.meta"])
W, b = t["weights"], t["bias"]
params = meta["space"]["params"]
X = np.stack([np.asarray(Image.open(p).convert("L"), dtype=np.float64).ravel() / 255.0 for p in a.images])
Y = X @ W.T.astype(np.float64) + b
est, k = [], 0
for p in params:
    if p["period"] is not None:
        est.append(np.degrees(np.arctan2(Y[:, k + 1], Y[:, k])) * p["period"] / 360.0 % p["period"]); k += 2
    else:
        est.append(Y[:, k]); k += 1
est = np.stack(est, 1)
out = subprocess.run([a.linpose, "predict", "--model", a.model, "--json"] + a.images, check=True, capture_output=True, text=True).stdout
ours = np.array([[json.loads(l)["pose"][p["name"]] for p in params] for l in out.splitlines()])
diff = np.abs(est - ours)
for j, p in enumerate(params):
    if p["period"] is not None:
        diff[:, j] = np.minimum(diff[:, j], p["period"] - diff[:, j])
print(f"weights {W.shape} {W.dtype}, bias {b.shape}; {len(a.images)} images; largest difference numpy vs linpose: {diff.max():.2e} degrees")
sys.exit(0 if diff.max() <= a.tol else 1)
