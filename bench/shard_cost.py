#!/usr/bin/env python3
"""What sharded training costs: time, peak memory and bytes moved against the number of images N
and of shards, with the command-line tool (`train --shard I/N --partial`, then `merge`), and a
cost model fitted to the figures, checked against them, and extrapolated.

One rendered duck (64 x 48, M = 3,072 pixels; `--size` to change) of up to 100,800 views;
training lists pick its first N views for each N. For each N and S in --shards:
- single: `train --stream --ridge 1e-3` in one process (the reference);
- S shards run as S processes at once (on this 2-core machine, 4 shards oversubscribe the cores:
  reported as measured), then `merge`. Shards are sets of images when N > M and of pixels when
  N <= M (the tool picks).
Each process's wall time and peak resident memory come from /usr/bin/time; bytes moved are the
partial files' sizes (what a cluster sends to the merge).

The cost model, per phase, for shards of images (N > M):
  shard   N_s max(t_read, M^2 / R_acc)           (decode overlapped with X^T X: M^2 flops an image)
  merge   S partials of 4 M^2 bytes read and added: S * 4 M^2 / B_merge
  finish  M^3 / 3 / R_chol                        (Cholesky of X^T X)
t_read, R_acc, B_merge and R_chol are fitted (medians over the rows) from the single-process and
merge timings' parts; the model's prediction is printed beside every measured row, then applied
to 10 million 160 x 120 images on 100 workers of this machine's kind.

  shard_cost.py [--sizes 1000,3000,10000,30000,100000] [--shards 1,2,4] [--json OUT]
"""
import argparse, json, math, os, statistics, subprocess, sys, tempfile, time
from concurrent.futures import ThreadPoolExecutor

here = os.path.dirname(os.path.abspath(__file__))
root = os.path.dirname(here)
ap = argparse.ArgumentParser()
ap.add_argument("--sizes", default="1000,3000,10000,30000,100000")
ap.add_argument("--shards", default="1,2,4")
ap.add_argument("--size", default="64x48")
ap.add_argument("--data", help="a rendered set to reuse (made by this script when absent)")
ap.add_argument("--json")
a = ap.parse_args()
sizes = [int(s) for s in a.sizes.split(",")]
shard_counts = [int(s) for s in a.shards.split(",")]
subprocess.run(["cargo", "build", "--release", "-q", "--bin", "linpose"], check=True, cwd=root)
cli = os.path.join(root, "target", "release", "linpose")
tmp = tempfile.mkdtemp(prefix="shard-cost-")
data = a.data or os.path.join(tmp, "duck")
if not os.path.exists(os.path.join(data, "poses.csv")):
    subprocess.run([cli, "synth", "--object", "duck", "--azimuth", "0:359.9:0.1", "--elevation", "32:78:1.7", "--size", a.size, "--out", data], check=True, stderr=subprocess.DEVNULL)
names = [line.split(",")[0] for line in open(os.path.join(data, "poses.csv")).read().splitlines()[1:] if line.strip()]
w, h = (int(v) for v in a.size.split("x"))
m = w * h


def timed(args):
    """Runs the tool under /usr/bin/time: (seconds, peak resident bytes, stderr)."""
    r = subprocess.run(["/usr/bin/time", "-f", "TIME %e %M", cli] + args, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"linpose {' '.join(args)} failed:\n{r.stderr}")
    line = [l for l in r.stderr.splitlines() if l.startswith("TIME ")][-1].split()
    return float(line[1]), int(line[2]) * 1024, r.stderr


rows = []
for n in sizes:
    if n > len(names):
        sys.exit(f"the set has {len(names)} views, fewer than {n}")
    # Evenly spread views, so every N covers the whole sphere of poses.
    pick = [names[i * len(names) // n] for i in range(n)]
    listing = os.path.join(tmp, f"list{n}.txt")
    open(listing, "w").write("\n".join(pick) + "\n")
    common = ["--data", data, "--train-list", listing, "--ridge", "1e-3"]
    single_s, single_rss, said = timed(["train"] + common + ["--stream", "--out", os.path.join(tmp, "single.st")])
    parts = {}
    for line in said.splitlines():
        # "reading 0.449 s (overlapped; waited 0.042 s), accumulating ... 0.787 s (...), solving 0.203 s"
        if "accumulating" in line:
            words = line.replace(",", " ").split()
            parts = {"read_s": float(words[words.index("reading") + 1]), "accumulate_s": float(words[words.index("accumulating") + 6]), "solve_s": float(words[words.index("solving") + 1])}
    for s in shard_counts:
        if s > max(n, m):
            continue
        files = [os.path.join(tmp, f"p{i}.st") for i in range(1, s + 1)]
        t0 = time.perf_counter()
        with ThreadPoolExecutor(s) as pool:
            shard = list(pool.map(lambda i: timed(["train"] + common + ["--shard", f"{i}/{s}", "--partial", files[i - 1]]), range(1, s + 1)))
        shards_s = time.perf_counter() - t0
        moved = sum(os.path.getsize(f) for f in files)
        merge_s, merge_rss, _ = timed(["merge"] + files + ["--out", os.path.join(tmp, "merged.st"), "--json", os.path.join(tmp, "merge.json")])
        mj = json.load(open(os.path.join(tmp, "merge.json")))
        row = {
            "n": n, "m": m, "split": "images" if n > m else "pixels", "shards": s,
            "single_s": single_s, "single_rss": single_rss, **parts,
            "shards_s": shards_s, "shard_rss": max(r[1] for r in shard), "bytes_moved": moved,
            "merge_s": merge_s, "merge_add_s": mj["merge_s"], "finish_s": mj["fit_s"], "merge_rss": merge_rss,
        }
        rows.append(row)
        for f in files:
            os.remove(f)
        print(json.dumps(row), flush=True)

# The cost model, fitted on the rows of shards of images (one shard: no concurrency).
img = [r for r in rows if r["split"] == "images"]
ones = [r for r in img if r["shards"] == 1] or img
model = {}
if img:
    r_acc = statistics.median(r["m"] ** 2 * r["n"] / r["accumulate_s"] for r in ones if r.get("accumulate_s"))
    t_read = statistics.median(r["read_s"] / r["n"] for r in ones if r.get("read_s"))
    b_merge = statistics.median(r["bytes_moved"] / max(r["merge_add_s"], 1e-9) for r in img)
    r_chol = statistics.median((r["m"] ** 3 / 3) / max(r["finish_s"], 1e-9) for r in img)
    model = {"R_acc_flops": r_acc, "t_read_s": t_read, "B_merge_bytes_s": b_merge, "R_chol_flops": r_chol}
    print("\nfitted:", json.dumps(model))
    cores = os.cpu_count() or 2

    def predict(n, m, s, machines):
        # Each shard's process reads on one thread while its other threads accumulate, so an
        # image costs max(t_read, M^2 / R_acc) of a machine; the S shards share `machines`
        # machines (here one: sharding on one machine adds the merge and buys nothing, since
        # one process already keeps both cores busy). Then the merge reads and adds S
        # partials and the finish factorises X^T X.
        return (n / machines) * max(t_read, m * m / r_acc) + s * 4 * m * m / b_merge + (m ** 3 / 3) / r_chol

    print(f"\n{'N':>7} {'S':>2} {'measured s':>10} {'model s':>8}")
    for r in img:
        p = predict(r["n"], r["m"], r["shards"], 1)
        r["model_s"] = p
        print(f"{r['n']:7d} {r['shards']:2d} {r['shards_s'] + r['merge_s']:10.2f} {p:8.2f}")
    # 10 million 160 x 120 images on 100 workers like this machine, a 10 Gbit/s network: each
    # reduce level moves one 4 M^2 partial per pair.
    big_m, big_n, workers = 160 * 120, 10_000_000, 100
    shard_s = (big_n / workers) * max(t_read, big_m ** 2 / r_acc)
    partial = 4 * big_m ** 2
    levels = math.ceil(math.log2(workers))
    reduce_s = levels * (partial / 1.25e9 + partial / b_merge)
    finish_s = (big_m ** 3 / 3) / r_chol
    model["ten_million"] = {"shard_s": shard_s, "reduce_s": reduce_s, "finish_s": finish_s, "total_s": shard_s + reduce_s + finish_s,
                            "partial_bytes": partial, "bytes_moved": workers * partial, "worker_peak_bytes": 2 * partial + 2 * 2048 * big_m * 4}
    print("\n10 million 160x120 images, 100 workers:", json.dumps(model["ten_million"]))
if a.json:
    json.dump({"rows": rows, "model": model}, open(a.json, "w"), indent=1)
