#!/usr/bin/env python3
"""COIL-20 objects anywhere in 320 x 240 scenes: the robust stage's search for the box, and the pose.

  locate.py [--coil DIR] [--objects 1-20] [--sets 0,0.2,0.4] [--canvas 320x240] [--scale 0.8:1.2]
            [--background texture] [--method refined] [--linpose BIN] [--jobs 2] [--work DIR]

For each object: its studio views (coil2dir.py); `linpose train --robust --train-step 10` on
them; per set, every view put somewhere in a 320 x 240 textured scene at a random scale in
0.8-1.2 (`linpose scene --canvas 320x240 --scale 0.8:1.2 --background texture --occlude F
--seed OBJECT`; scene.csv records the frame's box); `linpose eval` of the model on the scenes,
whose JSON gives each view's box. Prints, per set: the share of views whose box centre is within
3 pixels of the truth (over all 72 views of each object), the median and 95th-percentile centre
error, the box's scale error, the pose's unseen mean (the 36 views between the training views),
and eval's time per scene (its wall time over the views: the search, the repair and the
estimate); then each object's share within 3 pixels and unseen mean per set.
"""
import argparse, concurrent.futures as cf, csv, json, math, os, subprocess, sys, tempfile

here = os.path.dirname(os.path.abspath(__file__))
root = os.path.dirname(here)
ap = argparse.ArgumentParser()
ap.add_argument("--coil", default=os.path.join(root, "..", "shared", "datasets", "coil-20-proc"))
ap.add_argument("--objects", default="1-20")
ap.add_argument("--sets", default="0,0.2,0.4")
ap.add_argument("--canvas", default="320x240")
ap.add_argument("--scale", default="0.8:1.2")
ap.add_argument("--background", default="texture", help="scene's --background (texture, noise, a folder, or a level: 0 is the studio's black)")
ap.add_argument("--method", default="refined")
ap.add_argument("--linpose", default=os.path.join(root, "target", "release", "linpose"))
ap.add_argument("--jobs", type=int, default=2)
ap.add_argument("--work", default=None, help="working folder (default: a new temporary one)")
a = ap.parse_args()

work = a.work or tempfile.mkdtemp(prefix="locate-")
os.makedirs(work, exist_ok=True)
lo, _, hi = a.objects.partition("-")
objects = list(range(int(lo), int(hi or lo) + 1))
sets = [float(s) for s in a.sets.split(",")]
studio = os.path.join(work, "studio")


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{r.stderr}")
    return r


run([sys.executable, os.path.join(here, "coil2dir.py"), a.coil, studio, "--objects", a.objects])


def train(o):
    model = os.path.join(work, f"{a.method}-robust{o}.st")
    if not os.path.exists(model):
        run([a.linpose, "train", "--data", os.path.join(studio, f"obj{o}"), "--train-step", "10", "--method", a.method, "--robust", "--out", model])
    return model


def scenes(o, f):
    out = os.path.join(work, f"canvas{a.background.replace(os.sep, '_')}{f}", f"obj{o}")
    if not os.path.exists(os.path.join(out, "scene.csv")):
        run([a.linpose, "scene", "--data", os.path.join(studio, f"obj{o}"), "--out", out, "--canvas", a.canvas, "--scale", a.scale,
             "--background", a.background, "--occlude", str(f), "--seed", str(o)])
    return out


def evaluate(o, f):
    model, data = train(o), scenes(o, f)
    j = os.path.join(work, f"e{a.background.replace(os.sep, '_')}{f}-{o}.json")
    r = subprocess.run([a.linpose, "eval", "--model", model, "--data", data, "--json", j], capture_output=True, text=True)
    if not os.path.exists(j):
        raise SystemExit(f"eval of {model} on {data} failed:\n{r.stderr}")
    r = json.load(open(j))
    truth = {row["image"]: [float(v) for v in row["box"].split()] for row in csv.DictReader(open(os.path.join(data, "scene.csv")))}
    centre, scale = [], []
    for s in r["samples"]:
        t, b = truth[s["image"]], s["box"]
        centre.append(math.hypot(b[0] + b[2] / 2 - t[0] - t[2] / 2, b[1] + b[3] / 2 - t[1] - t[3] / 2))
        scale.append(abs(b[2] / t[2] - 1))
    return {"centre": centre, "scale": scale, "unseen": r["unseen"]["mean_deg"], "per_scene": r["predict_s"] / max(1, r["n_eval"]), "refused": len(r.get("rejected", []))}


with cf.ThreadPoolExecutor(a.jobs) as ex:
    list(ex.map(train, objects))
    res = dict(zip([(f, o) for f in sets for o in objects], ex.map(lambda k: evaluate(k[1], k[0]), [(f, o) for f in sets for o in objects])))


def pct(xs, q):
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(q * len(xs)))]


print(f"COIL-20 objects {a.objects}, {a.method} --robust trained on the studio views every 10 degrees; every view in a {a.canvas} scene ({a.background} background) at scale {a.scale}")
print(f"{'hidden':>6} {'views':>6} {'centre<=3px':>12} {'median px':>10} {'p95 px':>8} {'scale err':>10} {'unseen deg':>11} {'ms/scene':>9} {'refused':>8}")
for f in sets:
    c = [x for o in objects for x in res[(f, o)]["centre"]]
    s = [x for o in objects for x in res[(f, o)]["scale"]]
    u = sum(res[(f, o)]["unseen"] for o in objects) / len(objects)
    t = sum(res[(f, o)]["per_scene"] for o in objects) / len(objects)
    refused = sum(res[(f, o)]["refused"] for o in objects)
    print(f"{f:>6.1f} {len(c):>6} {sum(x <= 3 for x in c) / len(c):>12.3f} {pct(c, 0.5):>10.2f} {pct(c, 0.95):>8.2f} {sum(s) / len(s):>10.4f} {u:>11.3f} {1e3 * t:>9.1f} {refused:>8}")
for f in sets:
    print(f"per object at {f}:", " ".join(f"{o}:{sum(x <= 3 for x in res[(f, o)]['centre']) / len(res[(f, o)]['centre']):.2f}/{res[(f, o)]['unseen']:.2f}" for o in objects))
print(f"work folder: {work}")
