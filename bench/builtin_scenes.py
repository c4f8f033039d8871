#!/usr/bin/env python3
"""The built-in objects in scenes against the studio: the robust stage's error on one ring.

  builtin_scenes.py [--objects duck,mug] [--methods refined,eigenspace] [--linpose BIN] [--work DIR]

For each object: `linpose synth` around one ring (elevation 30, every 5 degrees of azimuth, the
default 160 x 120) on the studio backdrop and over texture with 20% hidden (`--background texture
--occlude 0.2 --seed 1`); each method trained on the studio views every 10 degrees with
`--robust`; `linpose eval` on the studio set and on a mixed set (the studio views at multiples of
10 degrees, the scene views between). Prints each object's and method's unseen mean error in
degrees, studio and scene, and the bar of issue 63 (twice the studio error plus 0.5).
"""
import argparse, json, os, subprocess, tempfile

here = os.path.dirname(os.path.abspath(__file__))
root = os.path.dirname(here)
ap = argparse.ArgumentParser()
ap.add_argument("--objects", default="duck,mug")
ap.add_argument("--methods", default="refined,eigenspace")
ap.add_argument("--linpose", default=os.path.join(root, "target", "release", "linpose"))
ap.add_argument("--work", default=None, help="working folder (default: a new temporary one)")
a = ap.parse_args()
work = a.work or tempfile.mkdtemp(prefix="builtin-scenes-")
os.makedirs(work, exist_ok=True)


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{r.stderr}")


def unseen(model, data):
    j = os.path.join(work, "eval.json")
    run([a.linpose, "eval", "--model", model, "--data", data, "--json", j])
    return json.load(open(j))["unseen"]["mean_deg"]


print(f"{'object':>8} {'method':>10} {'studio':>7} {'scene':>7} {'bar':>7}")
for o in a.objects.split(","):
    sets = {}
    for tag, extra in (("studio", []), ("scene", ["--background", "texture", "--occlude", "0.2", "--seed", "1"])):
        d = os.path.join(work, f"{o}-{tag}")
        if not os.path.exists(os.path.join(d, "poses.csv")):
            run([a.linpose, "synth", "--object", o, "--azimuth", "0:359:5", "--elevation", "30:30:1", "--out", d] + extra)
        sets[tag] = d
    mix = os.path.join(work, f"{o}-mix")
    if not os.path.exists(os.path.join(mix, "poses.csv")):
        os.makedirs(mix, exist_ok=True)
        rows = open(os.path.join(sets["studio"], "poses.csv")).read().split("\n")
        az = rows[0].split(",").index("azimuth")
        for r in rows[1:]:
            if r:
                name = r.split(",")[0]
                src = sets["studio"] if float(r.split(",")[az]) % 10 == 0 else sets["scene"]
                os.symlink(os.path.join(src, name), os.path.join(mix, name))
        open(os.path.join(mix, "poses.csv"), "w").write("\n".join(rows))
    for m in a.methods.split(","):
        model = os.path.join(work, f"{o}-{m}.st")
        if not os.path.exists(model):
            run([a.linpose, "train", "--data", sets["studio"], "--train-step", "10", "--method", m, "--robust", "--out", model])
        s, x = unseen(model, sets["studio"]), unseen(model, mix)
        print(f"{o:>8} {m:>10} {s:>7.3f} {x:>7.3f} {2 * s + 0.5:>7.3f}")
print(f"work folder: {work}")
