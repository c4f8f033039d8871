#!/usr/bin/env python3
"""Two builds of linpose timed side by side, alternating old and new in one run so both see the
same machine load: per-query time on the comparison's rows and whole commands.

  old_new.py --old OLD_BIN_DIR --new NEW_BIN_DIR --old-cache DIR --new-cache DIR
             [--rounds 5] [--reps 7] [--whole] [--experiment-rounds 2] [--json OUT]

Each BIN_DIR holds that build's `linpose` and `predict_timing` (target/release and
target/release/examples). Each cache is a `beyond_compare.py --cache` folder made by that build
(its models/, the rendered data/, and COIL-20 read from --coil), so each build times the model
files it wrote itself (the two builds' files may differ in format version, not in numbers: see
compare_runs.py). Per row and query kind (f32 features, 8-bit images), every round runs the old
build's predict_timing on its models, then the new one's on its models; a build's time for a
method is the median over rounds of predict_timing's median over --reps. With --whole it also
alternates whole commands (train + eval of the refined model on duck and on COIL-1, and
`linpose experiment` --experiment-rounds times). Prints one line per row and a summary of the
ratios new / old.
"""
import argparse, json, os, statistics, subprocess, sys, time

here = os.path.dirname(os.path.abspath(__file__))
root = os.path.dirname(here)
ap = argparse.ArgumentParser()
ap.add_argument("--old", required=True)
ap.add_argument("--new", required=True)
ap.add_argument("--old-cache", required=True)
ap.add_argument("--new-cache", required=True)
ap.add_argument("--coil", default=os.path.join(root, "..", "shared", "datasets", "coil-20-proc"))
ap.add_argument("--objects", default="duck,pot,cap,twin,column")
ap.add_argument("--noise", default="0,0.05,0.1")
ap.add_argument("--coil-objects", default="1-20")
ap.add_argument("--methods", default="refined,eigenspace,linear")
ap.add_argument("--rounds", type=int, default=5)
ap.add_argument("--reps", type=int, default=7)
ap.add_argument("--whole", action="store_true")
ap.add_argument("--experiment-rounds", type=int, default=2)
ap.add_argument("--json")
a = ap.parse_args()
methods = a.methods.split(",")


def timing(bin_dir, cache, data_args, key, noise, u8):
    models = [os.path.join(cache, "models", f"{key}-{m}.safetensors") for m in methods]
    cmd = [os.path.join(bin_dir, "predict_timing"), *data_args, "--noise", str(noise), "--reps", str(a.reps), *(["--u8"] if u8 else []), *models]
    out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    return [float(l.split()[0]) for l in out.splitlines() if "us/query" in l]


rows = []
for o in [x for x in a.objects.split(",") if x]:
    for n in [float(x) for x in a.noise.split(",")]:
        rows.append((o, n, lambda c, o=o: [os.path.join(c, "data", o)], o))
lo, _, hi = a.coil_objects.partition("-")
for k in range(int(lo), int(hi or lo) + 1):
    rows.append((f"coil{k}", 0.0, lambda c, k=k: [a.coil, "--object", str(k)], f"coil{k}"))

results = []
print(f"per-query microseconds, median of {a.rounds} alternated rounds (each a median of {a.reps}); ratio new / old")
print(f"{'data':<8} {'noise':>5} {'kind':<4} | " + " | ".join(f"{m:>10} old {'new':>7} {'ratio':>6}" for m in methods))
for name, noise, data, key in rows:
    for u8 in (False, True):
        per = {"old": [], "new": []}
        for _ in range(a.rounds):
            per["old"].append(timing(a.old, a.old_cache, data(a.old_cache), key, noise, u8))
            per["new"].append(timing(a.new, a.new_cache, data(a.new_cache), key, noise, u8))
        med = {w: [statistics.median(r[i] for r in per[w]) for i in range(len(methods))] for w in per}
        kind = "u8" if u8 else "f32"
        results.append(dict(data=name, noise=noise, kind=kind, **{f"{m}_{w}": med[w][i] for i, m in enumerate(methods) for w in med}))
        print(f"{name:<8} {noise:>5} {kind:<4} | " + " | ".join(f"{med['old'][i]:>14.2f} {med['new'][i]:>7.2f} {med['new'][i] / med['old'][i]:>6.3f}" for i in range(len(methods))))

print("summary of ratios new / old (median, min, max over rows):")
for m in methods:
    for kind in ("f32", "u8"):
        r = [x[f"{m}_new"] / x[f"{m}_old"] for x in results if x["kind"] == kind]
        print(f"  {m:<10} {kind:<4} median {statistics.median(r):.3f}  min {min(r):.3f}  max {max(r):.3f}  ({len(r)} rows)")

whole = []
if a.whole:
    tmp = f"/tmp/old_new-{os.getpid()}"
    os.makedirs(tmp, exist_ok=True)
    duck = os.path.join(a.new_cache, "data", "duck")
    jobs = [
        ("train+eval refined duck", lambda b, w: [[b, "train", "--data", duck, "--train-step", "9", "--method", "refined", "--out", f"{tmp}/{w}.st"], [b, "eval", "--model", f"{tmp}/{w}.st", "--data", duck]], a.rounds),
        ("train+eval refined COIL-1", lambda b, w: [[b, "train", "--data", a.coil, "--object", "1", "--train-step", "10", "--method", "refined", "--out", f"{tmp}/{w}.st"], [b, "eval", "--model", f"{tmp}/{w}.st", "--data", a.coil, "--object", "1"]], a.rounds),
        ("experiment", lambda b, w: [[b, "experiment", "--out", f"{tmp}/report-{w}"]], a.experiment_rounds),
    ]
    print("whole commands, seconds, alternated:")
    for label, cmds, rounds in jobs:
        t = {"old": [], "new": []}
        for _ in range(rounds):
            for w in ("old", "new"):
                b = os.path.join(getattr(a, w), "linpose")
                t0 = time.perf_counter()
                for c in cmds(b, w):
                    subprocess.run(c, check=True, capture_output=True)
                t[w].append(time.perf_counter() - t0)
        mo, mn = statistics.median(t["old"]), statistics.median(t["new"])
        whole.append(dict(job=label, old=t["old"], new=t["new"]))
        print(f"  {label:<28} old {mo:8.3f}  new {mn:8.3f}  ratio {mn / mo:.3f}   (old {', '.join(f'{x:.2f}' for x in t['old'])}; new {', '.join(f'{x:.2f}' for x in t['new'])})")
load = open("/proc/loadavg").read().split()[:3]
print(f"load average at the end: {' '.join(load)}")
if a.json:
    json.dump(dict(per_query=results, whole=whole, load=load), open(a.json, "w"), indent=1)
