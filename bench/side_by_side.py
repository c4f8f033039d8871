#!/usr/bin/env python3
"""One data set, one method, linpose and the numpy peer side by side in one run, REPEAT times
alternating: unseen mean error, in-process fit_s and predict_s, whole-process seconds. Medians.

  side_by_side.py DIR [--object O] --train-step S --method linear|eigenspace [--noise A] [--repeat 3]

DIR is in the directory format (poses.csv); with --object it is a COIL folder, converted for the
peer by coil2dir.py (symlinks, nothing copied).
"""
import argparse, json, os, statistics, subprocess, sys, tempfile, time

here = os.path.dirname(os.path.abspath(__file__))
root = os.path.dirname(here)
ap = argparse.ArgumentParser()
ap.add_argument("data")
ap.add_argument("--object", type=int)
ap.add_argument("--train-step", type=float, required=True)
ap.add_argument("--method", default="linear")
ap.add_argument("--peer-method", help="the peer's method (default: the same)")
ap.add_argument("--noise", type=float, default=0.0)
ap.add_argument("--repeat", type=int, default=3)
ap.add_argument("--python", default=os.path.join(root, "..", ".peer-venv", "bin", "python"))
ap.add_argument("--peer", default=os.path.join(root, "..", "shared", "peer", "peer.py"))
ap.add_argument("--linpose", default=os.path.join(root, "target", "release", "linpose"))
a = ap.parse_args()
tmp = tempfile.mkdtemp(prefix="sbs-")
peer_dir = a.data
obj = []
if a.object is not None:
    subprocess.run([sys.executable, os.path.join(here, "coil2dir.py"), a.data, tmp, "--objects", str(a.object)], check=True, capture_output=True)
    peer_dir = os.path.join(tmp, f"obj{a.object}")
    obj = ["--object", str(a.object)]
pm = a.peer_method or a.method
rows = {"linpose": [], "peer": []}
for _ in range(a.repeat):
    t0 = time.perf_counter()
    subprocess.run([a.python, a.peer, peer_dir, "--train-step", str(a.train_step), "--only", pm, "--noise", str(a.noise), "--json", f"{tmp}/p.json"], check=True, capture_output=True)
    whole = time.perf_counter() - t0
    p = json.load(open(f"{tmp}/p.json"))[pm]
    rows["peer"].append((p["unseen"]["mean_deg"], p["fit_s"], p["predict_s"], whole, p["model_bytes"]))
    t0 = time.perf_counter()
    subprocess.run([a.linpose, "train", "--data", a.data, *obj, "--train-step", str(a.train_step), "--method", a.method, "--out", f"{tmp}/m", "--json", f"{tmp}/t.json"], check=True, capture_output=True)
    subprocess.run([a.linpose, "eval", "--model", f"{tmp}/m", "--data", a.data, *obj, "--noise", str(a.noise), "--json", f"{tmp}/e.json"], check=True, capture_output=True)
    whole = time.perf_counter() - t0
    t, e = json.load(open(f"{tmp}/t.json")), json.load(open(f"{tmp}/e.json"))
    rows["linpose"].append((e["unseen"]["mean_deg"], t["fit_s"], e["predict_s"], whole, e["model_bytes"]))
med = {k: [statistics.median(c) for c in zip(*v)] for k, v in rows.items()}
l, p = med["linpose"], med["peer"]
print(f"{os.path.basename(os.path.normpath(a.data))}{' obj ' + str(a.object) if obj else ''}: linpose {a.method} vs peer {pm}, train step {a.train_step}, noise {a.noise}, medians of {a.repeat} alternating runs")
print(f"{'':10} {'unseen mean':>12} {'fit_s':>9} {'predict_s':>10} {'whole_s':>8} {'model bytes':>12}")
for k in ("linpose", "peer"):
    m = med[k]
    print(f"{k:10} {m[0]:>12.4f} {m[1]:>9.4f} {m[2]:>10.4f} {m[3]:>8.3f} {int(m[4]):>12}")
print(f"ratios linpose/peer: fit {l[1]/p[1]:.3f}, predict {l[2]/p[2]:.3f}, whole {l[3]/p[3]:.3f}")
