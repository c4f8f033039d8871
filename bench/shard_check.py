#!/usr/bin/env python3
"""Checks on a COIL folder that statistics merged from shards give the single-process fit,
through the command line: for every object, `linpose train` in one process against `linpose
train --shard I/N --partial FILE` run once per shard (each shard read from disk) and `linpose
merge`, for the linear model and the eigenspace, on the images as given (`--no-normalize`). Every
array of the two model files (read with numpy's safetensors loader) must agree to --tol relative
(the Frobenius norm of the difference over the single-process array's), and their metadata alike
(numbers to --tol; `stage_choice`, which only a one-process `train` records, aside). COIL's 72 views of 128 x 128 are fewer images than pixels, so the shards are
of pixels; shards of images are checked on rendered sets by the library's tests. Exits 1 on a
failure.

    python3 bench/shard_check.py COIL_DIR [--linpose BIN] [--shards 3] [--objects 1-20] [--tol 1e-9]
"""
import argparse, json, os, subprocess, sys, tempfile
import numpy as np
from safetensors import safe_open

root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ap = argparse.ArgumentParser()
ap.add_argument("coil")
ap.add_argument("--linpose", default=os.path.join(root, "target", "release", "linpose"))
ap.add_argument("--shards", type=int, default=3)
ap.add_argument("--objects", default="1-20")
ap.add_argument("--tol", type=float, default=1e-9)
a = ap.parse_args()
lo, _, hi = a.objects.partition("-")
objects = range(int(lo), int(hi or lo) + 1)


def run(*args):
    subprocess.run([a.linpose, *args], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


def load(path):
    with safe_open(path, "np") as f:
        tensors = {k: f.get_tensor(k).astype(np.float64) for k in f.keys()}
        meta = dict(f.metadata() or {})
    if "linpose.meta" in meta:
        # How the normalisation was decided: recorded by a one-process `train`, not by `merge`.
        m = json.loads(meta["linpose.meta"])
        m.pop("stage_choice", None)
        meta["linpose.meta"] = m
    return tensors, meta


def rel(want, got):
    den = np.linalg.norm(want)
    num = np.linalg.norm(want - got)
    return num / den if den > 0 else num


def meta_diff(want, got, where=""):
    """The largest relative difference between two metadata values (inf where they differ in kind)."""
    if isinstance(want, str) and isinstance(got, str):
        try:
            return meta_diff(json.loads(want), json.loads(got), where)
        except ValueError:
            return 0.0 if want == got else float("inf")
    if isinstance(want, dict) and isinstance(got, dict):
        if want.keys() != got.keys():
            return float("inf")
        return max([meta_diff(want[k], got[k], f"{where}.{k}") for k in want] or [0.0])
    if isinstance(want, list) and isinstance(got, list):
        if len(want) != len(got):
            return float("inf")
        return max([meta_diff(x, y, where) for x, y in zip(want, got)] or [0.0])
    if isinstance(want, (int, float)) and isinstance(got, (int, float)) and not isinstance(want, bool):
        return abs(want - got) / max(abs(want), 1e-300) if want != got else 0.0
    return 0.0 if want == got else float("inf")


worst = {}
failed = []
with tempfile.TemporaryDirectory(prefix="shard-check-") as tmp:
    for obj in objects:
        line = []
        for method in ("linear", "eigenspace"):
            base = ["train", "--data", a.coil, "--object", str(obj), "--method", method, "--no-normalize"]
            single = os.path.join(tmp, f"{method}-single.safetensors")
            merged = os.path.join(tmp, f"{method}-merged.safetensors")
            run(*base, "--out", single)
            parts = []
            for i in range(1, a.shards + 1):
                parts.append(os.path.join(tmp, f"{method}-part{i}.safetensors"))
                run(*base, "--shard", f"{i}/{a.shards}", "--partial", parts[-1])
            run("merge", *parts, "--out", merged)
            (tw, mw), (tg, mg) = load(single), load(merged)
            if tw.keys() != tg.keys():
                failed.append(f"object {obj} {method}: arrays {sorted(tw)} against {sorted(tg)}")
                continue
            r = max(rel(tw[k], tg[k]) if tw[k].shape == tg[k].shape else float("inf") for k in tw)
            m = meta_diff(mw, mg)
            worst[method] = max(worst.get(method, 0.0), r, m)
            line.append(f"{method} arrays {r:.1e}, metadata {m:.1e}")
            if not (r < a.tol and m < a.tol):
                bad = [k for k in tw if tw[k].shape != tg[k].shape or not rel(tw[k], tg[k]) < a.tol]
                failed.append(f"object {obj} {method}: arrays {r:.1e} ({', '.join(bad) or 'none'}), metadata {m:.1e}")
        print(f"object {obj:2}: " + "; ".join(line) + f" (relative, {a.shards} shards of pixels)", flush=True)

print("largest: " + ", ".join(f"{k} {v:.1e}" for k, v in worst.items()))
for f in failed:
    print(f"shard check: {f}", file=sys.stderr)
if failed:
    sys.exit(f"shard check: merged statistics differ from the single-process fit by {a.tol:g} or more")
print("shard check: passed")
