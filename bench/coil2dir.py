#!/usr/bin/env python3
"""Make per-object data sets in linpose's directory format (poses.csv + symlinks) from a COIL
folder, for tools that only read that format (the numpy peer). Nothing is copied.

  coil2dir.py COIL_DIR OUT_DIR [--objects 1-20]
"""
import argparse, os, re

ap = argparse.ArgumentParser()
ap.add_argument("coil")
ap.add_argument("out")
ap.add_argument("--objects", default="1-20")
a = ap.parse_args()
lo, _, hi = a.objects.partition("-")
pat = re.compile(r"^obj(\d+)__(\d+)\.png$")
files = {}
for f in os.listdir(a.coil):
    m = pat.match(f)
    if m:
        files.setdefault(int(m[1]), []).append((int(m[2]), f))
for o in range(int(lo), int(hi or lo) + 1):
    views = sorted(files.get(o, []))
    if not views:
        raise SystemExit(f"no images of object {o} in {a.coil}")
    by_degree = any(k > 71 for k, _ in views)
    d = os.path.join(a.out, f"obj{o}")
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, "poses.csv"), "w") as f:
        f.write("image,azimuth\n")
        for k, name in views:
            f.write(f"{name},{k if by_degree else 5 * k}\n")
            link = os.path.join(d, name)
            if not os.path.lexists(link):
                os.symlink(os.path.abspath(os.path.join(a.coil, name)), link)
print(a.out)
