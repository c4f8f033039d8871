#!/usr/bin/env python3
"""The normalisation stage as `linpose train` chooses it, against the images as given; whole
commands.

1. Each built-in object on the paper's grid (`linpose synth --object O`, trained every 9
   degrees), each method: what the default `train` chooses, and the unseen mean error clean and
   under +-5% and +-10% pixel noise, beside `--no-normalize`.
2. With --coil DIR: every COIL-20 object trained every 10 degrees, each method: the mean of the
   20 objects' unseen means with the default `train` and with `--no-normalize`, and how many
   objects got each choice.
3. With --zoo A:B: the zoo's seeds A to B-1 (`synth --random SEED --azimuth 0:355:5 --elevation
   30 --size 128x128`, trained every 10 degrees), each method: the mean over the seeds of the
   unseen means, default `train` and `--no-normalize`, clean and noisy, the choices made, and
   the seeds where the default is more than 5% worse than the images as given on a row.
4. With --moved: the built-in objects' views moved by up to 8 pixels and scaled 0.9-1.1
   (`synth --jitter 8,0.1,0 --jitter-seed 1`), the registered views' models queried with them:
   `--normalize` (forced) against `--no-normalize`.

    python3 bench/normalize.py [--linpose BIN] [--objects duck,pot,...] [--coil DIR] [--zoo A:B] [--moved]
"""
import argparse
import collections
import json
import os
import subprocess
import sys
import tempfile

METHODS = ["linear", "eigenspace", "refined"]
NOISE = ["0", "0.05", "0.1"]


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"failed: {' '.join(cmd)}\n{r.stderr}")
    return r


def train(b, data, step, method, flags, out):
    run([b, "train", *data, "--train-step", step, "--method", method, *flags, "--out", out, "--json", out + ".json"])
    return json.load(open(out + ".json")).get("stage_choice", {}).get("chosen", "off")


def unseen(b, model, data, noise, out):
    run([b, "eval", "--model", model, *data, "--noise", noise, "--json", out])
    r = json.load(open(out))
    return (r["unseen"] or r["all"])["mean_deg"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--linpose", default="target/release/linpose")
    ap.add_argument("--objects", default="duck,pot,cap,twin,column,mug,ring")
    ap.add_argument("--coil", default=None)
    ap.add_argument("--zoo", default=None)
    ap.add_argument("--moved", action="store_true")
    a = ap.parse_args()
    b = os.path.abspath(a.linpose)
    with tempfile.TemporaryDirectory() as t:
        ev = f"{t}/ev.json"
        print("| object | method | chosen | clean | +-5% | +-10% | as given: clean | +-5% | +-10% |")
        print("|---|---|---|---|---|---|---|---|---|")
        for o in a.objects.split(","):
            run([b, "synth", "--object", o, "--out", f"{t}/{o}"])
            data = ["--data", f"{t}/{o}"]
            for m in METHODS:
                cells = []
                chosen = train(b, data, "9", m, [], f"{t}/auto.st")
                train(b, data, "9", m, ["--no-normalize"], f"{t}/off.st")
                for model in ("auto", "off"):
                    cells += [f"{unseen(b, f'{t}/{model}.st', data, n, ev):.3f}" for n in NOISE]
                print(f"| {o} | {m} | {chosen} | {' | '.join(cells)} |", flush=True)
        if a.coil:
            print("\n| COIL-20 | method | default `train` | `--no-normalize` | choices |")
            print("|---|---|---|---|---|")
            for m in METHODS:
                s = {"auto": [], "off": []}
                counts = collections.Counter()
                for obj in range(1, 21):
                    data = ["--data", a.coil, "--object", str(obj)]
                    counts[train(b, data, "10", m, [], f"{t}/auto.st")] += 1
                    train(b, data, "10", m, ["--no-normalize"], f"{t}/off.st")
                    for model in s:
                        s[model].append(unseen(b, f"{t}/{model}.st", data, "0", ev))
                chosen = ", ".join(f"{c} {n}" for c, n in counts.most_common())
                print(f"| 20 objects | {m} | {sum(s['auto']) / 20:.3f} | {sum(s['off']) / 20:.3f} | {chosen} |", flush=True)
        if a.zoo:
            lo, hi = map(int, a.zoo.split(":"))
            print(f"\n| zoo {lo}-{hi - 1} | method | default: clean | +-5% | +-10% | as given: clean | +-5% | +-10% | choices | seeds worse by 5% |")
            print("|---|---|---|---|---|---|---|---|---|---|")
            for seed in range(lo, hi):
                run([b, "synth", "--random", str(seed), "--azimuth", "0:355:5", "--elevation", "30", "--size", "128x128", "--out", f"{t}/z{seed}"])
            for m in METHODS:
                sums = {"auto": [0.0] * 3, "off": [0.0] * 3}
                counts, worse, n = collections.Counter(), [], 0
                for seed in range(lo, hi):
                    data = ["--data", f"{t}/z{seed}"]
                    r = subprocess.run([b, "train", *data, "--train-step", "10", "--method", m, "--out", f"{t}/auto.st", "--json", f"{t}/auto.json"], capture_output=True)
                    if r.returncode:  # a fully symmetric object the linear model cannot fit
                        continue
                    n += 1
                    counts[json.load(open(f"{t}/auto.json"))["stage_choice"]["chosen"]] += 1
                    train(b, data, "10", m, ["--no-normalize"], f"{t}/off.st")
                    e = {model: [unseen(b, f"{t}/{model}.st", data, x, ev) for x in NOISE] for model in sums}
                    for model in sums:
                        sums[model] = [acc + v for acc, v in zip(sums[model], e[model])]
                    if any(x > 1.05 * y + 1e-9 for x, y in zip(e["auto"], e["off"])):
                        worse.append(str(seed))
                cells = [f"{v / n:.3f}" for model in ("auto", "off") for v in sums[model]]
                chosen = ", ".join(f"{c} {k}" for c, k in counts.most_common())
                print(f"| {n} seeds | {m} | {' | '.join(cells)} | {chosen} | {', '.join(worse) or 'none'} |", flush=True)
        if a.moved:
            print("\n| object | method | registered, `--normalize` | moved and scaled, `--normalize` | moved and scaled, `--no-normalize` | refused (moved) |")
            print("|---|---|---|---|---|---|")
            for o in a.objects.split(","):
                run([b, "synth", "--object", o, "--jitter", "8,0.1,0", "--jitter-seed", "1", "--out", f"{t}/{o}-moved"])
                for m in METHODS:
                    train(b, ["--data", f"{t}/{o}"], "9", m, ["--normalize"], f"{t}/norm.st")
                    train(b, ["--data", f"{t}/{o}"], "9", m, ["--no-normalize"], f"{t}/off.st")
                    reg = unseen(b, f"{t}/norm.st", ["--data", f"{t}/{o}"], "0", ev)
                    moved = unseen(b, f"{t}/norm.st", ["--data", f"{t}/{o}-moved"], "0", ev)
                    refused = len(json.load(open(ev)).get("rejected", []))
                    plain = unseen(b, f"{t}/off.st", ["--data", f"{t}/{o}-moved"], "0", ev)
                    print(f"| {o} | {m} | {reg:.3f} | {moved:.3f} | {plain:.3f} | {refused} |", flush=True)


if __name__ == "__main__":
    main()
