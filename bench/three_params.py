#!/usr/bin/env python3
"""Three pose parameters on a rendered object: model size, training time, time per query and the
unseen error (the rotation angle) of every method, with the confidence's flags.

The object is rendered at azimuth 0:354:6, elevation 32:77:9 and camera roll -30:30:10 (2,520
views of 160 x 120 by default); every method is trained on the every-other-value lattice
(azimuth every 12, elevation 32, 50, 68, roll -30, -10, 10, 30: 360 views) and evaluated on the
other views inside the training range (elevation at most 68). Time per query is the median of
`predict_timing --u8` (every view, batched, 8-bit as decoded from files) divided by the views.

    python3 bench/three_params.py [--object duck] [--size 160x120] [--linpose target/release/linpose]
        [--methods linear,eigenspace,refined] [--json OUT]
"""

import argparse
import csv
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_bin import bench_binary  # noqa: E402

GROSS = 20.0


def run(cmd):
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if r.returncode != 0:
        sys.exit(f"failed: {' '.join(cmd)}\n{r.stderr}")
    return r.stdout


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--object", default="duck")
    ap.add_argument("--size", default="160x120")
    ap.add_argument("--linpose", default="target/release/linpose")
    ap.add_argument("--methods", default="linear,eigenspace,refined")
    ap.add_argument("--reps", type=int, default=5, help="timing repetitions (median)")
    ap.add_argument("--json", help="write the figures here")
    a = ap.parse_args()
    timing = bench_binary("predict_timing")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        data = os.path.join(tmp, "set")
        run([a.linpose, "synth", "--object", a.object, "--out", data, "--azimuth", "0:354:6", "--elevation", "32:77:9", "--roll", "-30:30:10", "--size", a.size])
        with open(os.path.join(data, "poses.csv")) as f:
            poses = list(csv.DictReader(f))
        train = [p["image"] for p in poses if float(p["azimuth"]) % 12 == 0 and float(p["elevation"]) in (32, 50, 68) and float(p["roll"]) in (-30, -10, 10, 30)]
        listing = os.path.join(tmp, "train.txt")
        with open(listing, "w") as f:
            f.write("\n".join(train) + "\n")
        inside = {p["image"] for p in poses if float(p["elevation"]) <= 68}
        print(f"{a.object}: {len(poses)} views of {a.size}, {len(train)} trained on, {len(inside) - len(train)} unseen inside the training range", flush=True)
        for m in a.methods.split(","):
            model = os.path.join(tmp, f"{m}.safetensors")
            t0 = time.perf_counter()
            run([a.linpose, "train", "--data", data, "--train-list", listing, "--method", m, "--out", model])
            train_s = time.perf_counter() - t0
            out = os.path.join(tmp, f"{m}.json")
            run([a.linpose, "eval", "--model", model, "--data", data, "--json", out])
            r = json.load(open(out))
            unseen = [s for s in r["samples"] if not s["seen"] and s["image"] in inside]
            lines = run([timing, data, "--u8", "--reps", str(a.reps), model])
            # "   X us/query (min Y)  MODEL": the median per query.
            us = [float(line.split()[0]) for line in lines.splitlines() if "us/query" in line]
            row = {
                "method": m,
                "model_mb": os.path.getsize(model) / 1e6,
                "train_s": train_s,
                "per_query_us": us[0],
                "unseen": len(unseen),
                "unseen_mean_deg": statistics.mean(s["error_deg"] for s in unseen),
                "gross": sum(s["error_deg"] > GROSS for s in unseen),
                "flagged": sum(bool(s.get("flagged")) for s in unseen),
                "gross_flagged": sum(s["error_deg"] > GROSS and bool(s.get("flagged")) for s in unseen),
                "timing": lines.strip(),
            }
            rows.append(row)
            print(
                f"{m}: model {row['model_mb']:.2f} MB, train {train_s:.1f} s, per query {row['per_query_us']:.1f} us, "
                f"unseen mean {row['unseen_mean_deg']:.2f} deg over {row['unseen']}, gross {row['gross']} ({row['gross_flagged']} flagged), "
                f"flagged {row['flagged']} ({100 * row['flagged'] / row['unseen']:.1f}%)",
                flush=True,
            )
    if a.json:
        json.dump(rows, open(a.json, "w"), indent=1)


if __name__ == "__main__":
    main()
