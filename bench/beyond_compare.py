#!/usr/bin/env python3
"""Issue 6's yardstick: a candidate method against the peer's eigenspace (and linpose's own
eigenspace and linear model), on the paper's rendered grid under noise and on COIL-20.

  beyond_compare.py [--method refined] [--objects duck,pot,cap,twin,column] [--noise 0,0.05,0.1]
                    [--coil DIR | --no-coil] [--cache DIR] [--linpose BIN] [--extra "ARGS"]

Rendered objects: `linpose synth --object NAME` (the paper's 1760 views, 160x120) into the cache
folder once; training subset every 9 degrees. COIL-20: every object, train step 10, clean. The
peer (`peer.py --only eigenspace`) runs once per data set and noise level and its JSON is cached.
For each method: `linpose train` then `linpose eval --noise A`; per-query time = predict_s /
n_eval (same machine, same run), or with `--timing-reps R` the median of R batched predicts of
every view by the `predict_timing` bench target, the methods' models alternated in one process so
that they see the same load (`crates/linpose/benches/predict_timing.rs`, built by `cargo bench --no-run` when --predict-timing is not given). Prints one row per data set and noise: unseen mean errors,
model bytes and per-query microseconds, and whether the candidate meets the issue's bar
(error <= peer eigenspace, bytes <= linpose eigenspace, time <= linpose eigenspace). Exits 1 when
any row fails.
"""
import argparse, json, os, subprocess, sys
from bench_bin import bench_binary

here = os.path.dirname(os.path.abspath(__file__))
root = os.path.dirname(here)
ap = argparse.ArgumentParser()
ap.add_argument("--method", default="refined")
ap.add_argument("--baselines", default="eigenspace,linear")
ap.add_argument("--objects", default="duck,pot,cap,twin,column")
ap.add_argument("--noise", default="0,0.05,0.1")
ap.add_argument("--coil", default=os.path.join(root, "..", "shared", "datasets", "coil-20-proc"))
ap.add_argument("--coil-objects", default="1-20")
ap.add_argument("--no-coil", action="store_true")
ap.add_argument("--cache", default="/tmp/beyond-compare")
ap.add_argument("--peer", default=os.path.join(root, "..", "shared", "peer", "peer.py"))
ap.add_argument("--python", default=os.path.join(root, "..", ".peer-venv", "bin", "python"))
ap.add_argument("--linpose", default=os.path.join(root, "target", "release", "linpose"))
ap.add_argument("--extra", default="", help="extra arguments for `linpose train` of the candidate")
ap.add_argument("--json", help="write every row here")
ap.add_argument("--timing-reps", type=int, default=0, help="time the queries with the predict_timing bench target, alternating the methods, median of this many")
ap.add_argument("--timing-u8", action="store_true", help="with --timing-reps, also time 8-bit queries (predict_timing --u8, what `linpose predict` runs on image files); the bar then holds for both")
ap.add_argument("--predict-timing", default=None, help="the predict_timing bench binary (default: built by cargo bench --no-run)")
a = ap.parse_args()
if a.timing_reps > 0 and a.predict_timing is None:
    a.predict_timing = bench_binary("predict_timing")
os.makedirs(a.cache, exist_ok=True)
run = lambda cmd: subprocess.run(cmd, check=True, capture_output=True, text=True)
methods = [a.method] + [m for m in a.baselines.split(",") if m and m != a.method]


def peer(d, key, noise, step):
    pj = os.path.join(a.cache, "peer", f"{key}-{noise}.json")
    if not os.path.exists(pj):
        os.makedirs(os.path.dirname(pj), exist_ok=True)
        run([a.python, a.peer, d, "--train-step", str(step), "--only", "eigenspace", "--noise", str(noise), "--json", pj + ".tmp"])
        os.replace(pj + ".tmp", pj)
    return json.load(open(pj))["eigenspace"]["unseen"]["mean_deg"]


def ours(data_args, key, step, noises):
    out = {}
    for m in methods:
        model = os.path.join(a.cache, "models", f"{key}-{m}.safetensors")
        os.makedirs(os.path.dirname(model), exist_ok=True)
        tj = model + ".train.json"
        extra = a.extra.split() if m == a.method else []
        run([a.linpose, "train", *data_args, "--train-step", str(step), "--method", m, "--out", model, "--json", tj, *extra])
        tr = json.load(open(tj))
        for n in noises:
            ej = model + f".eval-{n}.json"
            run([a.linpose, "eval", "--model", model, *data_args, "--noise", str(n), "--json", ej])
            e = json.load(open(ej))
            out[(m, n)] = dict(err=e["unseen"]["mean_deg"], bytes=e["model_bytes"], us=e["predict_s"] / e["n_eval"] * 1e6, settings=tr["settings"])
    if a.timing_reps > 0:
        models = [os.path.join(a.cache, "models", f"{key}-{m}.safetensors") for m in methods]
        for n in noises:
            for key, flag in [("us", [])] + ([("us8", ["--u8"])] if a.timing_u8 else []):
                lines = run([a.predict_timing, *data_args[1:], "--noise", str(n), "--reps", str(a.timing_reps), *flag, *models]).stdout.splitlines()
                for m, line in zip(methods, [l for l in lines if "us/query" in l]):
                    out[(m, n)][key] = float(line.split()[0])
    return out


rows = []
noises = [float(x) for x in a.noise.split(",") if x]
for o in [x for x in a.objects.split(",") if x]:
    d = os.path.join(a.cache, "data", o)
    if not os.path.exists(os.path.join(d, "poses.csv")):
        run([a.linpose, "synth", "--object", o, "--out", d])
    res = ours(["--data", d], o, 9, noises)
    for n in noises:
        rows.append((o, n, peer(d, o, n, 9), res))
if not a.no_coil:
    cd = os.path.join(a.cache, "coil")
    run([sys.executable, os.path.join(here, "coil2dir.py"), a.coil, cd, "--objects", a.coil_objects])
    lo, _, hi = a.coil_objects.partition("-")
    for o in range(int(lo), int(hi or lo) + 1):
        res = ours(["--data", a.coil, "--object", str(o)], f"coil{o}", 10, [0.0])
        rows.append((f"coil{o}", 0.0, peer(os.path.join(cd, f"obj{o}"), f"coil{o}", 0.0, 10), res))

c, e = a.method, "eigenspace"
print(f"unseen mean error (degrees), model bytes, per-query us; candidate '{c}'")
hdr = f"{'data':<8} {'noise':>5} | {c:>9} {'eig':>8} {'peer eig':>8}" + ("" if "linear" not in methods else f" {'linear':>8}")
u8h = f" | {c+' u8':>9} {'eig u8':>8}" if a.timing_u8 else ""
print(hdr + f" | {c+' B':>10} {'eig B':>10} | {c+' us':>9} {'eig us':>8}{u8h} | {'b':>1} {'L':>3} {'interp':<6} ok")
fails, out = [], []
for (name, n, pe, res) in rows:
    r, g = res[(c, n)], res.get((e, n))
    lin = res.get(("linear", n))
    ok_err = r["err"] <= pe
    ok_b = g is None or r["bytes"] <= g["bytes"]
    ok_t = g is None or (r["us"] <= g["us"] and r.get("us8", 0) <= g.get("us8", 0))
    flag = "".join(x for x, ok in (("E", ok_err), ("B", ok_b), ("T", ok_t)) if not ok) or "yes"
    if flag != "yes":
        fails.append(f"{name}@{n}:{flag}")
    st = r["settings"] if isinstance(r["settings"], dict) else {}
    # The L of the search: the weighted search's, or 'p20' when the plain metric was chosen.
    L = ("p" if st.get("plain_error") is not None and not st.get("interpolation_variance") else "") + str(st.get("search_components") or st.get("components", ""))
    line = f"{name:<8} {n:>5} | {r['err']:>9.3f} {g['err'] if g else float('nan'):>8.3f} {pe:>8.3f}"
    if lin:
        line += f" {lin['err']:>8.3f}"
    line += f" | {r['bytes']:>10} {g['bytes'] if g else 0:>10} | {r['us']:>9.1f} {g['us'] if g else float('nan'):>8.1f}"
    if a.timing_u8:
        line += f" | {r.get('us8', float('nan')):>9.1f} {g.get('us8', float('nan')) if g else float('nan'):>8.1f}"
    line += f" | {st.get('bin', ''):>1} {L:>3} {st.get('interpolant', ''):<6} {flag}"
    print(line)
    out.append(dict(data=name, noise=n, peer_eigenspace=pe, **{f"{m}_{k}": res[(m, n)][k] for m in methods for k in ("err", "bytes", "us", "us8") if k in res[(m, n)]}, settings=r["settings"]))
if a.json:
    json.dump(out, open(a.json, "w"), indent=1)
print("all rows meet the bar" if not fails else "failing rows (E error, B bytes, T time): " + " ".join(fails))
sys.exit(1 if fails else 0)
