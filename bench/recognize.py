#!/usr/bin/env python3
"""Recognition and "none of these" on a many-object data set, every recogniser.

1. Every object known: train on every --train-step degrees, evaluate every view: recognition of
   all and unseen views, false rejections, pose error given the recognised object.
2. Objects left out: the objects are split into --folds folds (object i in fold i mod folds, in
   the data set's order); each fold is left out of training in turn, and every view evaluated:
   the share of the left-out objects' views reported unknown (true rejections) and of the known
   objects' unseen views reported unknown (false rejections), pooled over the folds, with the
   worst fold.

    python3 bench/recognize.py DATA [--linpose target/release/linpose] [--method refined] [--json OUT]
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time


def run(cmd):
    t = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"failed: {' '.join(cmd)}\n{p.stderr}")
    return time.perf_counter() - t


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("data")
    ap.add_argument("--linpose", default="target/release/linpose")
    ap.add_argument("--method", default="refined")
    ap.add_argument("--train-step", default="10")
    ap.add_argument("--folds", type=int, default=5)
    ap.add_argument("--recognizers", default="universal,linear")
    ap.add_argument("--json")
    a = ap.parse_args()
    out = {"data": a.data, "method": a.method, "rows": []}
    with tempfile.TemporaryDirectory() as tmp:
        model, ev = os.path.join(tmp, "m.st"), os.path.join(tmp, "e.json")
        for rec in a.recognizers.split(","):
            base = [a.linpose, "train", "--data", a.data, "--train-step", a.train_step, "--method", a.method, "--recognizer", rec, "--out", model]
            t_train = run(base)
            t_eval = run([a.linpose, "eval", "--model", model, "--data", a.data, "--json", ev])
            r = json.load(open(ev))
            objects = r["objects"]
            row = {
                "recognizer": rec,
                "all": r["recognition"]["all"],
                "unseen": r["recognition"]["unseen"],
                "false_rejections": r["unknown"]["false_rejections"],
                "pose_unseen_mean": r["pose"]["unseen"]["mean_deg"],
                "train_s": t_train,
                "eval_s": t_eval,
                "model_bytes": r["model_bytes"],
            }
            t_rej = t_n = f_rej = f_n = 0
            worst_true, worst_false = 1.0, 0.0
            for f in range(a.folds):
                left = [o for i, o in enumerate(objects) if i % a.folds == f]
                run(base + ["--leave-out", ",".join(left)])
                run([a.linpose, "eval", "--model", model, "--data", a.data, "--json", ev])
                e = json.load(open(ev))["unknown"]
                t_rej += round(e["true_rejections"] * e["unknown_views"])
                t_n += e["unknown_views"]
                f_rej += round(e["false_rejections"] * e["known_unseen_views"])
                f_n += e["known_unseen_views"]
                worst_true = min(worst_true, e["true_rejections"])
                worst_false = max(worst_false, e["false_rejections"])
            row.update({"left_out_rejected": t_rej / t_n, "known_unseen_rejected": f_rej / f_n, "worst_fold_rejected": worst_true, "worst_fold_false": worst_false})
            out["rows"].append(row)
            print(json.dumps(row), flush=True)
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(out, fh, indent=1)


if __name__ == "__main__":
    main()
