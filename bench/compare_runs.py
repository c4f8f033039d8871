#!/usr/bin/env python3
"""Are two builds of linpose the same estimator? Compares two `beyond_compare.py --cache` folders
made by two linpose binaries on the same data (each folder's `models/`): every model's tensors
and settings, and every evaluated view's estimate.

  compare_runs.py OLD_CACHE NEW_CACHE [--tol 1e-9]

Prints one line per model that differs (tensors, settings, model bytes) and per evaluation whose
estimates moved by more than --tol degrees (the views that moved, with their estimates), then a
summary. Exits 1 when anything differs beyond --tol or a file of OLD has no twin in NEW.
"""
import argparse, glob, json, os, struct, sys

ap = argparse.ArgumentParser()
ap.add_argument("old")
ap.add_argument("new")
ap.add_argument("--tol", type=float, default=1e-9, help="largest estimate change counted as the same (degrees)")
a = ap.parse_args()


def tensors(path):
    """The header's metadata and each tensor's (dtype, shape, bytes) of a safetensors file."""
    raw = open(path, "rb").read()
    (n,) = struct.unpack("<Q", raw[:8])
    header = json.loads(raw[8 : 8 + n])
    meta = header.pop("__metadata__", {})
    body = raw[8 + n :]
    out = {k: (v["dtype"], v["shape"], body[v["data_offsets"][0] : v["data_offsets"][1]]) for k, v in header.items()}
    return meta, out


def settings(meta):
    return json.loads(meta.get("linpose.meta", "{}")).get("settings")


problems, n_models, n_evals, n_views = [], 0, 0, 0
for old in sorted(glob.glob(os.path.join(a.old, "models", "*.safetensors"))):
    name = os.path.basename(old)
    new = os.path.join(a.new, "models", name)
    if not os.path.exists(new):
        problems.append(f"{name}: no twin in {a.new}")
        continue
    n_models += 1
    (mo, to), (mn, tn) = tensors(old), tensors(new)
    if set(to) != set(tn):
        problems.append(f"{name}: tensors {sorted(to)} -> {sorted(tn)}")
    for k in sorted(set(to) & set(tn)):
        if to[k] != tn[k]:
            problems.append(f"{name}: tensor '{k}' differs ({to[k][0]} {to[k][1]} -> {tn[k][0]} {tn[k][1]})")
    if settings(mo) != settings(mn):
        problems.append(f"{name}: settings {settings(mo)} -> {settings(mn)}")
    for ej in sorted(glob.glob(old + ".eval-*.json")):
        ejn = os.path.join(a.new, "models", os.path.basename(ej))
        if not os.path.exists(ejn):
            problems.append(f"{os.path.basename(ej)}: no twin")
            continue
        n_evals += 1
        eo, en = json.load(open(ej)), json.load(open(ejn))
        if eo["model_bytes"] != en["model_bytes"]:
            problems.append(f"{os.path.basename(ej)}: model bytes {eo['model_bytes']} -> {en['model_bytes']}")
        moved = []
        for so, sn in zip(eo["samples"], en["samples"]):
            n_views += 1
            d = max(abs(x - y) for x, y in zip(so["estimated"], sn["estimated"]))
            if so["image"] != sn["image"] or not d <= a.tol:
                moved.append(f"{so['image']} {so['estimated']} -> {sn['estimated']}")
        if len(eo["samples"]) != len(en["samples"]):
            problems.append(f"{os.path.basename(ej)}: {len(eo['samples'])} samples -> {len(en['samples'])}")
        if moved:
            uo, un = eo["unseen"]["mean_deg"], en["unseen"]["mean_deg"]
            problems.append(f"{os.path.basename(ej)}: {len(moved)} views moved (unseen mean {uo:.6f} -> {un:.6f}): " + "; ".join(moved[:5]))

print(f"{n_models} models, {n_evals} evaluations, {n_views} estimates compared (tolerance {a.tol} degrees)")
for p in problems:
    print("  " + p)
print("identical" if not problems else f"{len(problems)} differences")
sys.exit(1 if problems else 0)
