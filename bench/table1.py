#!/usr/bin/env python3
"""The paper's Table 1, measured: storage and time per query against the number of training views
N, for one, two and three pose parameters, of every method.

Okatani & Deguchi argue that the linear model stores M K numbers (M pixels, K encoded pose values)
against the parametric eigenspace's N L + M L (N manifold points, L eigenimages), and that the
eigenspace's manifold, searched point by point, grows as the product of the parameters' ranges.
For each number of parameters (1: azimuth at elevation 45; 2: azimuth x elevation; 3: azimuth x
elevation x camera roll) and each N of a ladder from about 10^2 to 10^6, the object is rendered
(`linpose synth`, images of --size, 32 x 24 by default) and every method is trained on all of the
views; for each point the table gives

- the model file's bytes, and the method's Table 1 formula with its terms' values and the numbers
  it gives (`train --json`'s `storage`, in f32 bytes: 4 per number), beside it;
- the training seconds (wall clock of `linpose train --no-normalize`: the images as rendered,
  rendering not included), the memory plan's path (in memory or streamed) and its estimate, and
  the peak resident memory (`/usr/bin/time`, where there is one);
- the time per query: the median over --reps of `predict_timing --u8` (every query of a fixed
  query set of off-grid views, batched; all cores) divided by the queries.

The refined method is trained only up to --refined-max-n views (10,560 views of three parameters
take it 69 s; its held-out choices fit many models, and past about 10^4 views of 32 x 24 the
memory plan refuses it: its estimate counts an N x N system); the eigenspace in memory only up to
--eigenspace-memory-max-n (past it, --stream: its second look keeps N x min(N - 1, M) numbers).
A data set is deleted as soon as it is measured; a million views of 32 x 24 take 4 GB on disk
(4 KB a file), so check `df` first.

    python3 bench/table1.py [--min-n 0] [--max-n 110000] [--size 32x24] [--params 1,2,3]
        [--methods linear,eigenspace,refined] [--refined-max-n 11000] [--json OUT] [--work DIR]
"""

import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_bin import bench_binary  # noqa: E402

# The grids of each number of parameters, about 10^2 to 10^6 views each: (N, synth arguments).
GRIDS = {
    1: [
        (100, ["--azimuth", "0:356.4:3.6", "--elevation", "45"]),
        (1000, ["--azimuth", "0:359.64:0.36", "--elevation", "45"]),
        (10000, ["--azimuth", "0:359.964:0.036", "--elevation", "45"]),
        (100000, ["--azimuth", "0:359.9964:0.0036", "--elevation", "45"]),
        (1000000, ["--azimuth", "0:359.99964:0.00036", "--elevation", "45"]),
    ],
    2: [
        (100, ["--azimuth", "0:342:18", "--elevation", "32:72:10"]),
        (990, ["--azimuth", "0:356:4", "--elevation", "32:72:4"]),
        (10800, ["--azimuth", "0:359.5:0.5", "--elevation", "32:76.8:3.2"]),
        (101520, ["--azimuth", "0:359.5:0.5", "--elevation", "32:76.8:0.32"]),
        (1015200, ["--azimuth", "0:359.9:0.1", "--elevation", "32:77:0.16"]),
    ],
    3: [
        (120, ["--azimuth", "0:324:36", "--elevation", "32:72:20", "--roll", "-30:30:20"]),
        (1260, ["--azimuth", "0:348:12", "--elevation", "32:77:9", "--roll", "-30:30:10"]),
        (10560, ["--azimuth", "0:354:6", "--elevation", "32:77:4.5", "--roll", "-30:30:4"]),
        (104160, ["--azimuth", "0:357:3", "--elevation", "32:77:1.5", "--roll", "-29.7:29.7:2.2"]),
        (1010160, ["--azimuth", "0:359:1", "--elevation", "32:77:1", "--roll", "-30:30:1"]),
    ],
}

# Off-grid query views of each number of parameters (the same for every N).
QUERIES = {
    1: ["--azimuth", "0.5:358.5:2", "--elevation", "45"],
    2: ["--azimuth", "1.5:355.5:6", "--elevation", "33.5:75.5:6"],
    3: ["--azimuth", "2.5:347.5:15", "--elevation", "35:75:10", "--roll", "-25:25:10"],
}


def run(cmd, check=True):
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if check and r.returncode != 0:
        sys.exit(f"failed: {' '.join(cmd)}\n{r.stderr}")
    return r


def synth(a, out, grid):
    run([a.linpose, "synth", "--object", a.object, "--out", out, "--size", a.size] + grid)


def measure(a, timing, params, n, data, queries, method, tmp):
    model = os.path.join(tmp, f"{method}.safetensors")
    summary = os.path.join(tmp, f"{method}.json")
    # The images as rendered (registered): the normalisation's choice on held-out views would
    # cost most of the training time and choose `off`.
    cmd = [a.linpose, "train", "--data", data, "--method", method, "--no-normalize", "--out", model, "--json", summary]
    if method == "eigenspace" and n > a.eigenspace_memory_max_n:
        cmd.append("--stream")
    if shutil.which("/usr/bin/time"):
        cmd = ["/usr/bin/time", "-f", "peak %M KB"] + cmd
    t0 = time.perf_counter()
    r = run(cmd, check=False)
    train_s = time.perf_counter() - t0
    peak = [int(line.split()[1]) * 1024 for line in r.stderr.splitlines() if line.startswith("peak ") and line.endswith(" KB")]
    if r.returncode != 0:
        print(f"  {method}: training failed: {r.stderr.strip().splitlines()[-1] if r.stderr.strip() else r.returncode}", flush=True)
        return {"params": params, "n": n, "method": method, "error": r.stderr.strip()}
    s = json.load(open(summary))
    plan = next((line for line in r.stderr.splitlines() if line.startswith("memory:")), "")
    lines = run([timing, queries, "--u8", "--reps", str(a.reps), model]).stdout
    # "   X us/query (min Y)  MODEL": the median per query.
    us = [float(line.split()[0]) for line in lines.splitlines() if "us/query" in line]
    row = {
        "params": params,
        "n": n,
        "method": method,
        "m": s["n_features"],
        "file_bytes": s["file_bytes"],
        "model_bytes": s["model_bytes"],
        "formula": s["storage"]["formula"],
        "terms": dict(s["storage"]["terms"]),
        "formula_numbers": s["storage"]["numbers"],
        "formula_bytes": 4 * s["storage"]["numbers"],
        "train_s": train_s,
        "path": s["memory"]["path"],
        "estimate_bytes": s["memory"]["estimate_bytes"],
        "peak_bytes": peak[0] if peak else None,
        "plan": plan,
        "per_query_us": us[0],
        "timing": lines.strip(),
    }
    os.remove(model)
    return row


def fmt_bytes(b):
    for unit, f in (("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if b >= f:
            return f"{b / f:.3g} {unit}"
    return f"{b} B"


def terms(row):
    return ", ".join(f"{k}={v}" for k, v in row["terms"].items())


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--object", default="duck")
    ap.add_argument("--size", default="32x24")
    ap.add_argument("--linpose", default="target/release/linpose")
    ap.add_argument("--params", default="1,2,3", help="numbers of pose parameters")
    ap.add_argument("--methods", default="linear,eigenspace,refined")
    ap.add_argument("--max-n", type=float, default=1.1e5, help="largest number of training views (default: up to about 10^5; 1.1e6 adds the million-view sets)")
    ap.add_argument("--min-n", type=float, default=0, help="smallest number of training views")
    ap.add_argument("--refined-max-n", type=float, default=11000, help="train the refined method only up to this many views")
    ap.add_argument("--eigenspace-memory-max-n", type=float, default=20000, help="beyond this many views the eigenspace is trained with --stream")
    ap.add_argument("--reps", type=int, default=3, help="timing repetitions (median)")
    ap.add_argument("--work", help="folder for the data sets (default: a temporary folder)")
    ap.add_argument("--json", help="write the rows here")
    a = ap.parse_args()
    timing = bench_binary("predict_timing")
    methods = a.methods.split(",")
    rows = []
    work = tempfile.mkdtemp(prefix="table1-", dir=a.work)
    try:
        for params in [int(p) for p in a.params.split(",")]:
            queries = os.path.join(work, f"queries{params}")
            synth(a, queries, QUERIES[params])
            for n, grid in GRIDS[params]:
                if not a.min_n <= n <= a.max_n:
                    continue
                data = os.path.join(work, f"set{params}_{n}")
                t0 = time.perf_counter()
                synth(a, data, grid)
                print(f"{params} parameter(s), {n} views of {a.size}: rendered in {time.perf_counter() - t0:.0f} s", flush=True)
                for m in methods:
                    if m == "refined" and n > a.refined_max_n:
                        continue
                    row = measure(a, timing, params, n, data, queries, m, work)
                    rows.append(row)
                    if "error" not in row:
                        print(
                            f"  {m}: file {fmt_bytes(row['file_bytes'])}, formula {row['formula']} = {row['formula_numbers']} numbers ({terms(row)}), "
                            f"train {row['train_s']:.1f} s ({row['path']}, peak {fmt_bytes(row['peak_bytes'] or 0)}, estimate {fmt_bytes(row['estimate_bytes'])}), "
                            f"per query {row['per_query_us']:.1f} us",
                            flush=True,
                        )
                if a.json:
                    json.dump(rows, open(a.json, "w"), indent=1)
                shutil.rmtree(data, ignore_errors=True)
            shutil.rmtree(queries)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    print()
    print("| D | N | method | file | formula | numbers x 4 B | terms | train s | path | peak | us/query |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        if "error" in r:
            print(f"| {r['params']} | {r['n']} | {r['method']} | failed | | | | | | | |")
            continue
        print(
            f"| {r['params']} | {r['n']} | {r['method']} | {fmt_bytes(r['file_bytes'])} | {r['formula']} | {fmt_bytes(r['formula_bytes'])} | {terms(r)} | "
            f"{r['train_s']:.2f} | {r['path']} | {fmt_bytes(r['peak_bytes'] or 0)} | {r['per_query_us']:.1f} |"
        )
    if a.json:
        json.dump(rows, open(a.json, "w"), indent=1)


if __name__ == "__main__":
    main()
