#!/usr/bin/env python3
"""What a query costs with and without the robust stage: the built-in duck at 128 x 128.

  scene_cost.py [--linpose BIN] [--runs 3] [--work DIR]

Renders the duck around one ring (elevation 30, every degree of azimuth) on the studio backdrop
and over texture with 20% hidden (`linpose synth --background texture --occlude 0.2 --seed 1`);
trains each method on the studio views every 10 degrees, plain and with `--robust`; and runs
`linpose eval` of each model on the 180 odd azimuths of each set, one thread
(RAYON_NUM_THREADS=1), the best of --runs runs. Prints a markdown table: per method and set, the
microseconds per query (eval's predict time over the views, the confidence included) and the
unseen mean error in degrees.
"""
import argparse, json, os, subprocess, tempfile

here = os.path.dirname(os.path.abspath(__file__))
root = os.path.dirname(here)
ap = argparse.ArgumentParser()
ap.add_argument("--linpose", default=os.path.join(root, "target", "release", "linpose"))
ap.add_argument("--runs", type=int, default=3)
ap.add_argument("--work", default=None, help="working folder (default: a new temporary one)")
a = ap.parse_args()
work = a.work or tempfile.mkdtemp(prefix="scene-cost-")
os.makedirs(work, exist_ok=True)
env = dict(os.environ, RAYON_NUM_THREADS="1")


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True, env=env)
    if r.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{r.stderr}")


def render(name, extra):
    out = os.path.join(work, name)
    if not os.path.exists(os.path.join(out, "poses.csv")):
        run([a.linpose, "synth", "--object", "duck", "--size", "128x128", "--elevation", "30:30:1", "--azimuth", "0:359:1", "--out", out] + extra)
    odd = out + "-odd"
    if not os.path.exists(os.path.join(odd, "poses.csv")):
        os.makedirs(odd, exist_ok=True)
        rows = open(os.path.join(out, "poses.csv")).read().split("\n")
        head = rows[0].split(",")
        az = head.index("azimuth")
        keep = [rows[0]]
        for r in rows[1:]:
            if r and int(float(r.split(",")[az])) % 2 == 1:
                name = r.split(",")[0]
                os.symlink(os.path.join(out, name), os.path.join(odd, name))
                keep.append(r)
        open(os.path.join(odd, "poses.csv"), "w").write("\n".join(keep) + "\n")
    return out, odd


studio, studio_odd = render("studio", [])
_, scene_odd = render("scene", ["--background", "texture", "--occlude", "0.2", "--seed", "1"])
print("| method | studio, plain | studio, `--robust` | texture 20%, plain | texture 20%, `--robust` |")
print("|---|---|---|---|---|")
for method in ("linear", "eigenspace", "refined"):
    cells = {}
    for robust in (False, True):
        model = os.path.join(work, f"{method}{'-robust' if robust else ''}.st")
        if not os.path.exists(model):
            run([a.linpose, "train", "--data", studio, "--train-step", "10", "--method", method, "--out", model] + (["--robust"] if robust else []))
        for tag, data in (("studio", studio_odd), ("scene", scene_odd)):
            best, err = float("inf"), None
            for k in range(a.runs):
                j = os.path.join(work, f"e-{method}-{robust}-{tag}.json")
                run([a.linpose, "eval", "--model", model, "--data", data, "--json", j])
                r = json.load(open(j))
                best = min(best, r["predict_s"] / r["n_eval"])
                err = r["unseen"]["mean_deg"]
            cells[(tag, robust)] = f"{1e6 * best:.0f} us, {err:.2f}"
    print(f"| {method} | {cells['studio', False]} | {cells['studio', True]} | {cells['scene', False]} | {cells['scene', True]} |")
print(f"work folder: {work}")
