#!/usr/bin/env python3
"""Recognition with and without poses, from Python (`linpose.ObjectRecognizer`).

Fitted with poses, each object's manifold is the curve through its training views at their
poses; fitted without (`fit(X, y)`), it is the views' points. On one many-object data set, both
ways, every recogniser, the same training views (every --train-step degrees):

1. every object known: the share of unseen views recognised and reported unknown;
2. objects left out in --folds folds (object i in fold i mod folds): the share of the left-out
   objects' views reported unknown, and of the known objects' unseen views, pooled;
3. the time of one fit and one predict of every view, every object known.

    python3 bench/recognize_views.py DATA [--train-step 10] [--folds 5]

DATA is a folder of object folders (each a data set with poses.csv) or a COIL folder.
"""

import argparse
import os
import re
import time

import numpy as np

import linpose


def read(data):
    """Every object's views: {name: (images, poses, params)}, in the data set's order."""
    coil = sorted({int(m.group(1)) for f in os.listdir(data) if (m := re.match(r"obj(\d+)__\d+\.png$", f))})
    if coil:
        return {f"obj{k}": linpose.read_dataset(data, object=k)[:3] for k in coil}
    return {o: linpose.read_dataset(os.path.join(data, o))[:3] for o in sorted(os.listdir(data)) if os.path.isdir(os.path.join(data, o))}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("data")
    ap.add_argument("--train-step", type=float, default=10.0)
    ap.add_argument("--folds", type=int, default=5)
    a = ap.parse_args()
    objects = read(a.data)
    names = list(objects)
    params = [tuple(p) for p in objects[names[0]][2]]
    train = {o: linpose.train_mask(p, params, a.train_step) for o, (_, p, _) in objects.items()}

    def fit(kind, posed, known):
        X = np.concatenate([objects[o][0][train[o]] for o in known])
        y = np.concatenate([[o] * int(train[o].sum()) for o in known])
        # The pose models do not take part in recognition; the eigenspace's fits views the
        # linear model refuses (one view at two poses, as a symmetric object gives).
        est = linpose.ObjectRecognizer(recognizer=kind, params=params, pose=linpose.EigenspacePose())
        if posed:
            return est.fit(X, y, np.concatenate([objects[o][1][train[o]] for o in known]))
        return est.fit(X, y)

    print(f"{a.data}: {len(names)} objects, {sum(len(v[0]) for v in objects.values())} views, training every {a.train_step:g} degrees")
    print("| recogniser | poses | unseen recognised | unseen unknown | left out unknown | known unseen unknown (left out) | fit s | predict s |")
    print("|---|---|---|---|---|---|---|---|")
    for kind in ("universal", "linear"):
        for posed in (True, False):
            t = time.perf_counter()
            est = fit(kind, posed, names)
            fit_s = time.perf_counter() - t
            t = time.perf_counter()
            pred = {o: est.predict(objects[o][0]) for o in names}
            predict_s = time.perf_counter() - t
            right = sum(int((pred[o][~train[o]] == o).sum()) for o in names)
            unknown = sum(int((pred[o][~train[o]] == est.unknown_label_).sum()) for o in names)
            n_unseen = sum(int((~train[o]).sum()) for o in names)
            rejected = left = false = n_known = 0
            for f in range(a.folds):
                out = [o for i, o in enumerate(names) if i % a.folds == f]
                known = [o for o in names if o not in out]
                e = fit(kind, posed, known)
                for o in out:
                    p = e.predict(objects[o][0])
                    rejected += int((p == e.unknown_label_).sum())
                    left += len(p)
                for o in known:
                    p = e.predict(objects[o][0][~train[o]])
                    false += int((p == e.unknown_label_).sum())
                    n_known += len(p)
            print(
                f"| {kind} | {'yes' if posed else 'no'} | {100 * right / n_unseen:.2f}% | {100 * unknown / n_unseen:.2f}% "
                f"| {100 * rejected / left:.2f}% | {100 * false / n_known:.2f}% | {fit_s:.3f} | {predict_s:.3f} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
