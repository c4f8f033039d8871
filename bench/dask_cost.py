#!/usr/bin/env python3
"""linpose.dask.fit on a LocalCluster of this machine: time, each worker's peak memory and the
bytes the workers moved, against the number of images N and of workers (one thread each, one
shard a worker), beside the one-process `linpose train` of the same images.

The data set is a rendered duck folder (bench/shard_cost.py makes one: 64 x 48, 100,800 views);
N views are taken evenly over it. The linear model with ridge 1e-3. For each row a fresh
cluster (so its workers' peak resident memory is the row's); the fit's time is the median of
--reps fits on it. Bytes moved: the workers' incoming transfers (Dask's count) times the size of
a partial (shards of images are all one size), plus the model's bytes to the client.

  dask_cost.py --data DIR [--sizes 1000,10000,100000] [--workers 1,2,4] [--reps 2] [--json OUT]
"""
import argparse, json, os, statistics, subprocess, sys, time

import numpy as np
from distributed import Client, LocalCluster

import linpose
from linpose import _linpose
import linpose.dask
import linpose._estimators

here = os.path.dirname(os.path.abspath(__file__))
root = os.path.dirname(here)
ap = argparse.ArgumentParser()
ap.add_argument("--data", required=True)
ap.add_argument("--sizes", default="1000,10000,100000")
ap.add_argument("--workers", default="1,2,4")
ap.add_argument("--reps", type=int, default=2)
ap.add_argument("--json")
a = ap.parse_args()
lines = open(os.path.join(a.data, "poses.csv")).read().splitlines()[1:]
names = [os.path.abspath(os.path.join(a.data, l.split(",")[0])) for l in lines if l.strip()]
poses_all = np.array([[float(v) for v in l.split(",")[1:]] for l in lines if l.strip()])
params = ["elevation", ("azimuth", 360.0)]
cli = os.path.join(root, "target", "release", "linpose")


def peak_rss():
    import resource
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


def incoming(dask_worker):
    return dask_worker.state.transfer_incoming_count_total


def main():
    rows = []
    for n in (int(s) for s in a.sizes.split(",")):
        pick = [i * len(names) // n for i in range(n)]
        paths, poses = [names[i] for i in pick], poses_all[pick]
        listing = f"/tmp/dask-cost-{n}.txt"
        open(listing, "w").write("\n".join(os.path.basename(p) for p in paths) + "\n")
        t0 = time.perf_counter()
        r = subprocess.run(["/usr/bin/time", "-f", "TIME %e %M", cli, "train", "--data", a.data, "--train-list", listing, "--ridge", "1e-3", "--stream", "--out", "/tmp/dask-cost.st"], capture_output=True, text=True)
        if r.returncode:
            sys.exit(r.stderr)
        one = [l for l in r.stderr.splitlines() if l.startswith("TIME")][-1].split()
        split, units, w, h, partial = _linpose.partial_plan("linear", [("ridge", "0.001")], paths, poses, linpose._estimators.resolve_params(params, 2))
        for workers in (int(s) for s in a.workers.split(",")):
            with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, memory_limit=0, dashboard_address=":0") as cluster, Client(cluster) as client:
                times = []
                for _ in range(a.reps):
                    t = time.perf_counter()
                    model = linpose.dask.fit(paths, poses, client=client, params=params, ridge=1e-3)
                    times.append(time.perf_counter() - t)
                transfers = sum(client.run(incoming).values())
                peak = max(client.run(peak_rss).values())
            row = {"n": n, "split": split, "workers": workers, "shards": min(workers, units), "fit_s": statistics.median(times), "fits": times,
                   "worker_peak_bytes": peak, "transfers": transfers, "partial_bytes": partial,
                   "bytes_moved_per_fit": (transfers / a.reps) * partial if split == "images" else None,
                   "one_process_s": float(one[1]), "one_process_peak_bytes": int(one[2]) * 1024}
            rows.append(row)
            print(json.dumps(row), flush=True)
    if a.json:
        json.dump(rows, open(a.json, "w"), indent=1)


# The workers are started as new processes, which import this file: run only as the script.
if __name__ == "__main__":
    main()
