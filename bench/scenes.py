#!/usr/bin/env python3
"""COIL-20 in scenes: robust against plain estimation, and the numpy eigenspace as the yardstick.

  scenes.py [--coil DIR] [--objects 1-20] [--sets 0,0.2,0.4] [--methods eigenspace,refined]
            [--linpose BIN] [--python PY] [--peer PEER] [--no-peer] [--jobs 2] [--work DIR]
            [--recognize]

For each object: its studio views (coil2dir.py) and, per set, every view put into a scene by
`linpose scene --background texture --occlude F --seed OBJECT`; a mixed data set holds the studio
views at multiples of 10 degrees (the training views) and the scene views between (the queries).
linpose trains each method on the studio views every 10 degrees, plain and with `--robust`, and
`linpose eval` reads the mixed set: its unseen mean is the error over the scene views. The peer
(`peer.py --train-step 10 --only eigenspace`) reads the mixed set the same way. (Recognition of
the objects together: --recognize.)

With --recognize: one many-object model of the objects (the universal eigenspace with refined
pose models, no normalisation stage), plain and with `--robust`, trained on their studio views
every 10 degrees, evaluated on the objects' mixed sets together, and on their studio views (the
views between in the studio: the robust stage must leave them as they are); the peer
(`recognize.py --train-step 10`) on the same mixed sets. Prints per set the recognition rate of
the scene views (every object known, `--unknown off`, and under the calibrated unknown-object
rule), their pose unseen mean (views recognised as their object) and the per-query time of
eval, plain, robust and the peer's.

Prints, per set and per method, the unseen mean over the objects (plain, robust, peer) and the
per-query time of eval (predict seconds / views, over the mixed set: half studio views, half
scenes), then each object's robust refined error per set.
"""
import argparse, concurrent.futures as cf, json, os, subprocess, sys, tempfile

here = os.path.dirname(os.path.abspath(__file__))
root = os.path.dirname(here)
ap = argparse.ArgumentParser()
ap.add_argument("--coil", default=os.path.join(root, "..", "shared", "datasets", "coil-20-proc"))
ap.add_argument("--objects", default="1-20")
ap.add_argument("--sets", default="0,0.2,0.4")
ap.add_argument("--methods", default="eigenspace,refined")
ap.add_argument("--linpose", default=os.path.join(root, "target", "release", "linpose"))
ap.add_argument("--python", default=os.path.join(root, "..", ".peer-venv", "bin", "python"))
ap.add_argument("--peer", default=os.path.join(root, "..", "shared", "peer", "peer.py"))
ap.add_argument("--no-peer", action="store_true")
ap.add_argument("--jobs", type=int, default=2)
ap.add_argument("--work", default=None, help="working folder (default: a new temporary one)")
ap.add_argument("--recognize", action="store_true", help="one many-object model of the objects (see the doc)")
ap.add_argument("--peer-recognize", default=os.path.join(root, "..", "shared", "peer", "recognize.py"))
a = ap.parse_args()

work = a.work or tempfile.mkdtemp(prefix="scenes-")
os.makedirs(work, exist_ok=True)
lo, _, hi = a.objects.partition("-")
objects = list(range(int(lo), int(hi or lo) + 1))
sets = [float(s) for s in a.sets.split(",")]
methods = a.methods.split(",")
studio = os.path.join(work, "studio")


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{r.stderr}")
    return r


run([sys.executable, os.path.join(here, "coil2dir.py"), a.coil, studio, "--objects", a.objects])


def mixed(o, f):
    """The mixed set of object o at hidden share f: studio views at multiples of 10, scene views between."""
    scene = os.path.join(work, f"scene{f}", f"obj{o}")
    mix = os.path.join(work, f"mix{f}", f"obj{o}")
    if os.path.exists(os.path.join(mix, "poses.csv")):
        return mix
    run([a.linpose, "scene", "--data", os.path.join(studio, f"obj{o}"), "--out", scene, "--background", "texture", "--occlude", str(f), "--seed", str(o)])
    os.makedirs(mix, exist_ok=True)
    rows = open(os.path.join(studio, f"obj{o}", "poses.csv")).read().split("\n")
    out = [rows[0]]
    for r in rows[1:]:
        if not r:
            continue
        name, az = r.split(",")
        src = os.path.join(studio if float(az) % 10 == 0 else os.path.join(work, f"scene{f}"), f"obj{o}", name)
        link = os.path.join(mix, name)
        if not os.path.lexists(link):
            os.symlink(os.path.realpath(src), link)
        out.append(r)
    open(os.path.join(mix, "poses.csv"), "w").write("\n".join(out) + "\n")
    return mix


def train(o, method, robust):
    model = os.path.join(work, f"{method}{'-robust' if robust else ''}{o}.st")
    if not os.path.exists(model):
        run([a.linpose, "train", "--data", os.path.join(studio, f"obj{o}"), "--train-step", "10", "--method", method, "--out", model] + (["--robust"] if robust else []))
    return model


def evaluate(model, data, tag):
    j = os.path.join(work, f"{tag}.json")
    r = subprocess.run([a.linpose, "eval", "--model", model, "--data", data, "--json", j], capture_output=True, text=True)
    if not os.path.exists(j):
        raise SystemExit(f"eval of {model} on {data} failed:\n{r.stderr}")
    r = json.load(open(j))
    c = r.get("confidence") or {}
    return r["unseen"]["mean_deg"], r["predict_s"] / max(1, r["n_eval"]), (c.get("n", 0), c.get("gross", 0), c.get("flagged", 0), c.get("gross_flagged", 0))


def peer(o, f):
    j = os.path.join(work, f"peer{f}-{o}.json")
    run([a.python, a.peer, mixed(o, f), "--train-step", "10", "--only", "eigenspace", "--json", j])
    return json.load(open(j))["eigenspace"]["unseen"]["mean_deg"]




def recognition():
    """The many-object part (--recognize)."""
    with cf.ThreadPoolExecutor(a.jobs) as ex:
        for f in sets:
            list(ex.map(lambda o: mixed(o, f), objects))
    tag = a.objects.replace("-", "_")
    models = {}
    for robust in (False, True):
        m = os.path.join(work, f"objects{tag}{'-robust' if robust else ''}.st")
        if not os.path.exists(m):
            run([a.linpose, "train", "--data", studio, "--train-step", "10", "--method", "refined", "--no-normalize", "--out", m] + (["--robust"] if robust else []))
        models[robust] = m

    def ev(model, data, name, *extra):
        j = os.path.join(work, f"{name}.json")
        run([a.linpose, "eval", "--model", model, "--data", data, "--json", j, *extra])
        r = json.load(open(j))
        return r["recognition"]["unseen"], (r["pose"]["unseen"] or {}).get("mean_deg", float("nan")), r["predict_s"] / max(1, r["n_eval"])

    def peer_rec(f):
        j = os.path.join(work, f"peer-rec{f}-{tag}.json")
        if not os.path.exists(j):
            d = os.path.join(work, f"mix{f}")
            run([a.python, a.peer_recognize, *[os.path.join(d, f"obj{o}") for o in objects], "--train-step", "10", "--json", j])
        e = json.load(open(j))["eigenspace"]
        return e["recognition_unseen"], e["pose_unseen"]["mean_deg"], e["pose_unseen_recognised"]["mean_deg"], e["predict_s"] / json.load(open(j))["n_eval"]

    print(f"COIL-20 objects {a.objects} as one model (universal recogniser, refined poses), trained on the studio views every 10 degrees")
    print(f"{'set':>8} {'recognised (off) plain':>22} {'robust':>7} {'(calibrated) plain':>18} {'robust':>7} {'pose plain':>10} {'robust':>7} {'ms/query plain':>14} {'robust':>7} | peer: {'recognised':>10} {'pose':>7} {'pose rec.':>9} {'ms/q':>6}")
    for f in ["studio"] + sets:
        data = studio if f == "studio" else os.path.join(work, f"mix{f}")
        r = {}
        for robust in (False, True):
            r[robust, "off"] = ev(models[robust], data, f"rec-{f}-{robust}-{tag}-off", "--unknown", "off")
            r[robust, "cal"] = ev(models[robust], data, f"rec-{f}-{robust}-{tag}-cal")
        p = peer_rec(f) if (f != "studio" and not a.no_peer) else (float("nan"),) * 4
        print(f"{str(f):>8} {r[False, 'off'][0]:>22.4f} {r[True, 'off'][0]:>7.4f} {r[False, 'cal'][0]:>18.4f} {r[True, 'cal'][0]:>7.4f} "
              f"{r[False, 'off'][1]:>10.3f} {r[True, 'off'][1]:>7.3f} {1e3 * r[False, 'off'][2]:>14.3f} {1e3 * r[True, 'off'][2]:>7.3f} | "
              f"{p[0]:>16.4f} {p[1]:>7.3f} {p[2]:>9.3f} {1e3 * p[3]:>6.3f}")
    print(f"work folder: {work}")


if a.recognize:
    recognition()
    sys.exit(0)

with cf.ThreadPoolExecutor(a.jobs) as ex:
    for f in sets:
        list(ex.map(lambda o: mixed(o, f), objects))
    models = {(o, m, r): ex.submit(train, o, m, r) for o in objects for m in methods for r in (False, True)}
    models = {k: v.result() for k, v in models.items()}
    evals = {(f, o, m, r): ex.submit(evaluate, models[(o, m, r)], mixed(o, f), f"e{f}-{m}{r}-{o}") for f in sets for o in objects for m in methods for r in (False, True)}
    peers = {} if a.no_peer else {(f, o): ex.submit(peer, o, f) for f in sets for o in objects}
    evals = {k: v.result() for k, v in evals.items()}
    peers = {k: v.result() for k, v in peers.items()}

mean = lambda xs: sum(xs) / len(xs)
print(f"COIL-20 objects {a.objects}, trained on the studio views every 10 degrees, queried at the views between in texture scenes")
print(f"{'hidden':>6} {'method':>10} {'plain':>8} {'robust':>8} {'peer':>8} {'ms/query plain':>15} {'robust':>7}")
for f in sets:
    p = mean([peers[(f, o)] for o in objects]) if peers else float("nan")
    for m in methods:
        pl = [evals[(f, o, m, False)] for o in objects]
        rb = [evals[(f, o, m, True)] for o in objects]
        print(f"{f:>6.1f} {m:>10} {mean([x[0] for x in pl]):>8.3f} {mean([x[0] for x in rb]):>8.3f} {p:>8.3f} {1e3 * mean([x[1] for x in pl]):>15.3f} {1e3 * mean([x[1] for x in rb]):>7.3f}")
print("the confidence over the scene views (all objects pooled): gross errors (> 20 degrees) flagged, and estimates not gross flagged (false flags)")
print(f"{'hidden':>6} {'method':>10} {'gross plain':>11} {'flagged':>8} {'false':>7} {'gross robust':>12} {'flagged':>8} {'false':>7}")
for f in sets:
    for m in methods:
        cols = []
        for r in (False, True):
            n, g, fl, gf = (sum(evals[(f, o, m, r)][2][i] for o in objects) for i in range(4))
            cols.append(f"{g:>11d} {gf / g if g else float('nan'):>8.3f} {(fl - gf) / (n - g) if n > g else float('nan'):>7.3f}")
        print(f"{f:>6.1f} {m:>10} {cols[0]} {' ' + cols[1]}")
print("per object (robust refined):", " ".join(f"{o}:{evals[(f, o, 'refined', True)][0]:.2f}" for f in sets for o in objects) if "refined" in methods else "")
print(f"work folder: {work}")
