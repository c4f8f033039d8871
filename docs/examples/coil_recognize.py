#!/usr/bin/env python3
"""Several objects on a COIL-style turntable set, from Python: which object, "none of these",
then the pose.

    python docs/examples/coil_recognize.py COIL_DIR [--leave-out 3] [--out distances.png]

COIL_DIR holds images named objO__K.png (view K of object O, 72 views 5 degrees apart, as in
COIL-20). The script loads every object with Pillow, trains a recogniser with refined pose models
on every 10 degrees of every object but one, then reports the views between (recognised, pose
error) and the object left out (reported unknown), plots each view's distance to its nearest
object against that object's threshold, and compares the two recognisers with GridSearchCV.
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
from sklearn.model_selection import GridSearchCV, StratifiedKFold

import linpose

ap = argparse.ArgumentParser()
ap.add_argument("coil_dir")
ap.add_argument("--leave-out", type=int, default=3, help="the object kept out of training")
ap.add_argument("--out", default="distances.png")
a = ap.parse_args()

# 1. Images, objects and poses as numpy arrays: (n, h, w) uint8, labels, azimuths in degrees.
files = glob.glob(os.path.join(a.coil_dir, "obj*__*.png"))
parts = [re.search(r"obj(\d+)__(\d+)\.png$", f) for f in files]
files, parts = zip(*sorted(((f, p) for f, p in zip(files, parts) if p), key=lambda t: (int(t[1].group(1)), int(t[1].group(2)))))
X = np.stack([np.asarray(Image.open(f).convert("L")) for f in files])  # or cv2.imread(f, cv2.IMREAD_GRAYSCALE)
objects = np.array([f"obj{p.group(1)}" for p in parts])
azimuth = 5.0 * np.array([int(p.group(2)) for p in parts])  # COIL-20: 72 views, 5 degrees apart
params = [("azimuth", 360)]
print(f"{len(X)} images of {X.shape[2]}x{X.shape[1]}, {len(set(objects))} objects")

# 2. Train on every 10 degrees of every object but one.
left_out = objects == f"obj{a.leave_out}"
train = linpose.train_mask(azimuth, ["azimuth"], 10) & ~left_out
rec = linpose.ObjectRecognizer(pose=linpose.RefinedPose(), params=params)
rec.fit(X[train], objects[train], azimuth[train])

# 3. The views between: recognised, and their pose from their object's own model.
unseen = ~train & ~left_out
label = rec.predict(X[unseen])
right = label == objects[unseen]
err = linpose.pose_error(azimuth[unseen][right], rec.predict_pose(X[unseen][right]), params)
print(f"unseen views: {right.mean():.2%} recognised, {(label == rec.unknown_label_).mean():.2%} reported unknown; "
      f"pose error of the recognised, mean {err.mean():.2f} degrees")

# 4. The object left out: "none of these".
print(f"obj{a.leave_out}, left out: {(rec.predict(X[left_out]) == rec.unknown_label_).mean():.2%} of its views reported unknown")

# 5. Each view's distance to its nearest object, against that object's threshold (the largest
# distance of its held-out training views): the first stage of "none of these". A view within it
# is then measured in the object's own eigenspace, which rejects most of the left-out object's.
threshold = dict(zip(rec.classes_, rec.settings_["thresholds"]))
fig, ax = plt.subplots(figsize=(7, 3.5))
for mask, name in ((unseen, "unseen views of known objects"), (left_out, f"obj{a.leave_out} (left out)")):
    _, nearest, distance, _ = rec.recognize(X[mask])
    ax.hist(distance / np.array([threshold[n] for n in nearest]), bins=40, alpha=0.6, label=name)
ax.axvline(1.0, color="k", lw=1)
ax.set_title("first stage: beyond 1, unknown; within, the object's own eigenspace decides", fontsize=9)
ax.set_xlabel("distance to the nearest object / its threshold")
ax.set_ylabel("views")
ax.legend()
fig.tight_layout()
fig.savefig(a.out, dpi=120)
print(f"wrote {a.out}")

# 6. The two recognisers compared by GridSearchCV on the training views (accuracy on held-out
# training views; the poses go along with each fold's views).
search = GridSearchCV(
    linpose.ObjectRecognizer(params=params),
    {"recognizer": ["universal", "linear"]},
    cv=StratifiedKFold(3, shuffle=True, random_state=0),
)
search.fit(X[train], objects[train], poses=azimuth[train])
print(f"GridSearchCV: recognizer={search.best_params_['recognizer']} (held-out accuracy {search.best_score_:.2%})")

# 7. The model file is the command line's: `linpose predict --model cell.safetensors IMAGE`.
rec.save("cell.safetensors")
