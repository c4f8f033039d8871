#!/usr/bin/env bash
# Whole-process timing, side by side in one run: linpose train + eval against the numpy peer's
# linear part, on one COIL-20 object (train step 10). Needs hyperfine and ../.peer-venv.
#   bench/whole_process.sh [OBJECT]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd); root=$(dirname "$here")
coil=${COIL:-$root/../shared/datasets/coil-20-proc}; py=${PEER_PY:-$root/../.peer-venv/bin/python}
obj=${1:-1}
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
python3 "$here/coil2dir.py" "$coil" "$tmp" --objects "$obj" >/dev/null
bin=$root/target/release/linpose
hyperfine -N --warmup 2 --runs ${RUNS:-15} --export-json "$tmp/h.json" \
  -n linpose "bash -c '$bin train --data $coil --object $obj --train-step 10 --out $tmp/m.st && $bin eval --model $tmp/m.st --data $coil --object $obj >/dev/null'" \
  -n peer-linear "$py $root/../shared/peer/peer.py $tmp/obj$obj --train-step 10 --only linear"
python3 - "$tmp/h.json" <<'PY'
import json, sys
r = {x["command"]: x for x in json.load(open(sys.argv[1]))["results"]}
a, b = r["linpose"]["median"], r["peer-linear"]["median"]
print(f"median whole process: linpose {a*1000:.1f} ms, peer {b*1000:.1f} ms, ratio peer/linpose {b/a:.1f}x")
PY
