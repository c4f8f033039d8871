#!/usr/bin/env python3
"""Recognition and "none of these" on a many-object data set, every recogniser.

1. Every object known: train on every --train-step degrees, evaluate every view: recognition of
   all and unseen views, false rejections, pose error given the recognised object.
2. Objects left out: the objects are split into --folds folds (object i in fold i mod folds, in
   the data set's order); each fold is left out of training in turn, and every view evaluated:
   the share of the left-out objects' views reported unknown (true rejections) and of the known
   objects' unseen views reported unknown (false rejections), pooled over the folds, with the
   worst fold.

3. With --peer PYTHON: the numpy/scikit-learn yardstick (`recognize.py`, in ../shared/peer) on
   the same objects in the same run (a COIL folder is laid out per object for it with symlinks),
   every command timed whole, --repeats times: medians, and the ratio of linpose's train + eval
   to the peer's run.

    python3 bench/recognize.py DATA [--linpose target/release/linpose] [--method refined]
        [--normalize WHAT] [--peer ../.peer-venv/bin/python] [--repeats 3] [--json OUT]
"""

import argparse
import json
import os
import re
import statistics
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


def left_out_rates(linpose, train, model, data, objects, folds, ev):
    """Objects left out in FOLDS folds (object i in fold i mod FOLDS), each fold in turn: TRAIN
    (a train command writing MODEL) without it, then eval on DATA. Pooled over the folds: the
    share of the left-out objects' views reported unknown and of the known objects' unseen
    views, with the worst fold's."""
    t_rej = t_n = f_rej = f_n = 0
    worst_true, worst_false = 1.0, 0.0
    for f in range(folds):
        left = [o for i, o in enumerate(objects) if i % folds == f]
        run(train + ["--leave-out", ",".join(left)])
        run([linpose, "eval", "--model", model, "--data", data, "--json", ev])
        e = json.load(open(ev))["unknown"]
        t_rej += round(e["true_rejections"] * e["unknown_views"])
        t_n += e["unknown_views"]
        f_rej += round(e["false_rejections"] * e["known_unseen_views"])
        f_n += e["known_unseen_views"]
        worst_true = min(worst_true, e["true_rejections"])
        worst_false = max(worst_false, e["false_rejections"])
    return {"left_out_rejected": t_rej / t_n, "known_unseen_rejected": f_rej / f_n, "worst_fold_rejected": worst_true, "worst_fold_false": worst_false}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("data")
    ap.add_argument("--linpose", default="target/release/linpose")
    ap.add_argument("--method", default="refined")
    ap.add_argument("--train-step", default="10")
    ap.add_argument("--folds", type=int, default=5)
    ap.add_argument("--recognizers", default="universal,linear")
    ap.add_argument("--peer", help="python with numpy, scipy, scikit-learn, pillow")
    ap.add_argument("--peer-script", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "shared", "peer", "recognize.py"))
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--normalize", default=None, help="train --normalize WHAT (default: what train chooses)")
    ap.add_argument("--json")
    a = ap.parse_args()
    out = {"data": a.data, "method": a.method, "normalize": a.normalize, "rows": []}
    with tempfile.TemporaryDirectory() as tmp:
        if a.peer:
            out["side_by_side"] = side_by_side(a, tmp)
            print(json.dumps(out["side_by_side"]), flush=True)
        model, ev = os.path.join(tmp, "m.st"), os.path.join(tmp, "e.json")
        for rec in a.recognizers.split(","):
            base = [a.linpose, "train", "--data", a.data, "--train-step", a.train_step, "--method", a.method, "--recognizer", rec, "--out", model]
            if a.normalize:
                base += ["--normalize", a.normalize]
            t_train = run(base + ["--json", os.path.join(tmp, "train.json")])
            chosen = json.load(open(os.path.join(tmp, "train.json")))["settings"].get("stage_choice", {}).get("chosen")
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
                "refused": len(r.get("rejected", [])),
                "stage": chosen,
            }
            row.update(left_out_rates(a.linpose, base, model, a.data, objects, a.folds, ev))
            out["rows"].append(row)
            print(json.dumps(row), flush=True)
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(out, fh, indent=1)


def object_dirs(data, tmp):
    """The objects of DATA as folders in the directory format: its subfolders, or a COIL folder's
    objects laid out per object (symlinks, nothing copied)."""
    subs = sorted(d for d in os.listdir(data) if os.path.isfile(os.path.join(data, d, "poses.csv")))
    if subs:
        return [os.path.join(data, d) for d in subs]
    pat = re.compile(r"^obj(\d+)__(\d+)\.png$")
    views = {}
    for f in os.listdir(data):
        m = pat.match(f)
        if m:
            views.setdefault(int(m[1]), []).append((int(m[2]), f))
    dirs = []
    for o in sorted(views):
        v = sorted(views[o])
        by_degree = any(k > 71 for k, _ in v)
        d = os.path.join(tmp, "peer", f"obj{o}")
        os.makedirs(d, exist_ok=True)
        with open(os.path.join(d, "poses.csv"), "w") as fh:
            fh.write("image,azimuth\n")
            for k, name in v:
                fh.write(f"{name},{k if by_degree else 5 * k}\n")
                os.symlink(os.path.abspath(os.path.join(data, name)), os.path.join(d, name))
        dirs.append(d)
    return dirs


def side_by_side(a, tmp):
    """linpose (universal recogniser, --method) and the peer, whole commands, medians of repeats."""
    dirs = object_dirs(a.data, tmp)
    model, ev, pj = os.path.join(tmp, "s.st"), os.path.join(tmp, "s.json"), os.path.join(tmp, "p.json")
    times = {"linpose_train_s": [], "linpose_eval_s": [], "peer_s": []}
    for _ in range(a.repeats):
        times["linpose_train_s"].append(run([a.linpose, "train", "--data", a.data, "--train-step", a.train_step, "--method", a.method, "--out", model]))
        times["linpose_eval_s"].append(run([a.linpose, "eval", "--model", model, "--data", a.data, "--json", ev]))
        times["peer_s"].append(run([a.peer, a.peer_script, *dirs, "--train-step", a.train_step, "--json", pj]))
    med = {k: statistics.median(v) for k, v in times.items()}
    r, p = json.load(open(ev)), json.load(open(pj))
    pe = p["eigenspace"]
    return {
        "linpose": {"recognition_unseen": r["recognition"]["unseen"], "false_rejections": r["unknown"]["false_rejections"],
                    "pose_unseen_mean": r["pose"]["unseen"]["mean_deg"], "model_bytes": r["model_bytes"],
                    "train_s": med["linpose_train_s"], "eval_s": med["linpose_eval_s"]},
        "peer_eigenspace": {"recognition_unseen": pe["recognition_unseen"], "pose_unseen_mean": pe["pose_unseen"]["mean_deg"],
                            "model_bytes": pe["model_bytes"], "fit_s": pe["fit_s"], "predict_s": pe["predict_s"], "load_s": p["load_s"]},
        "peer_linear": {"recognition_unseen": p["linear"]["recognition_unseen"], "model_bytes": p["linear"]["model_bytes"], "fit_s": p["linear"]["fit_s"]},
        "peer_run_s": med["peer_s"],
        "ratio_to_peer_run": (med["linpose_train_s"] + med["linpose_eval_s"]) / med["peer_s"],
        "ratio_to_peer_eigenspace": (med["linpose_train_s"] + med["linpose_eval_s"]) / (pe["fit_s"] + pe["predict_s"] + p["load_s"]),
        "repeats": a.repeats,
    }


if __name__ == "__main__":
    main()
