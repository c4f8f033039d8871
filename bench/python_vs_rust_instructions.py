#!/usr/bin/env python3
"""Work done, not time: the instructions one fit or predict takes from Python and in a Rust
process, counted by valgrind's callgrind, which counts the same for the same binary and inputs
whatever else the machine runs. On a shared machine the wall times of bench/python_vs_rust.py
move by more than the 5% it compares; the instruction counts tell whether the Python side does
more work.

Each side runs in its own process under callgrind on one thread (RAYON_NUM_THREADS=1: idle
workers spinning would add counts that depend on the scheduler): the estimator in this
interpreter (the installed `linpose` package) and crates/linpose/examples/fit_predict_timing.rs
in `--serve` mode (`fit 0` / `predict 0`: one call per request). Each runs the call once and
five times; the difference over four is the instructions per call, its set-up (imports,
decoding, the first fit) cancelled. The Rust side's count includes its request loop (reading a
line, timing, printing), which the Python side's loop does not have: about 0.14 million
instructions a request, which matters only beside a call as short as COIL-20's linear predict.

    python3 bench/python_vs_rust_instructions.py DATA --train-step S --method M --what fit|predict [--object O]

Needs valgrind, the package installed in the interpreter running this script's children
(--python, default this one) and the example built
(`cargo build --release -p linpose --example fit_predict_timing`). Slow: the interpreter's start
under callgrind takes about a minute.
"""
import argparse
import os
import re
import subprocess
import sys

CHILD = """
import sys, linpose, numpy as np
data, obj, step, method, what, k = sys.argv[1], int(sys.argv[2]) or None, int(sys.argv[3]), sys.argv[4], sys.argv[5], int(sys.argv[6])
X, y, params, _ = linpose.read_dataset(data, obj)
train = linpose.train_mask(y, params, step)
Xt, yt = np.ascontiguousarray(X[train]), np.ascontiguousarray(y[train])
est = {"linear": linpose.LinearPose, "eigenspace": linpose.EigenspacePose, "refined": linpose.RefinedPose}[method](params=params)
est.fit(Xt, yt)
for _ in range(k):
    est.fit(Xt, yt) if what == "fit" else est.predict(X)
"""


def collected(cmd, stdin=None):
    """The instructions callgrind collected over the whole run of `cmd`."""
    env = {**os.environ, "RAYON_NUM_THREADS": "1"}
    r = subprocess.run(["valgrind", "--tool=callgrind", "--callgrind-out-file=/dev/null", *cmd], input=stdin, capture_output=True, text=True, env=env)
    m = re.search(r"Collected : (\d+)", r.stderr)
    if r.returncode != 0 or not m:
        sys.exit(f"failed: {' '.join(cmd)}\n{r.stderr[-2000:]}")
    return int(m.group(1))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("data")
    ap.add_argument("--train-step", type=int, required=True)
    ap.add_argument("--method", required=True, choices=["linear", "eigenspace", "refined"])
    ap.add_argument("--what", required=True, choices=["fit", "predict"])
    ap.add_argument("--object", type=int, default=0)
    ap.add_argument("--python", default=sys.executable)
    ap.add_argument("--timing", default="target/release/examples/fit_predict_timing")
    a = ap.parse_args()
    obj = ["--object", str(a.object)] if a.object else []
    rust = [a.timing, a.data, *obj, "--train-step", str(a.train_step), "--method", a.method, "--serve"]
    per = {}
    for side in ("python", "rust"):
        counts = []
        for k in (1, 5):
            if side == "python":
                counts.append(collected([a.python, "-c", CHILD, a.data, str(a.object), str(a.train_step), a.method, a.what, str(k)]))
            else:
                counts.append(collected(rust, stdin=f"{a.what} 0\n" * k))
        per[side] = (counts[1] - counts[0]) / 4
    print(f"{a.method} {a.what}: python {per['python'] / 1e6:.2f} M instructions, rust {per['rust'] / 1e6:.2f} M "
          f"({100 * (per['python'] / per['rust'] - 1):+.2f}%)")


if __name__ == "__main__":
    main()
