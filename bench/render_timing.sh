#!/usr/bin/env bash
# Issue 3: render and write the three paper objects' full grids (3 x 1760 PNG images of 160x120)
# with `linpose synth`, timed as one whole command. Prints wall seconds and the load average.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd); bin=$root/target/release/linpose
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
for run in 1 2 3; do
  rm -rf "$tmp"/*
  s=$(date +%s.%N)
  for o in duck pot cap; do "$bin" synth --object $o --out "$tmp/$o" >/dev/null; done
  e=$(date +%s.%N)
  echo "run $run: $(echo "$e - $s" | bc) s for $(ls "$tmp"/*/*.png | wc -l) images; load average $(cut -d' ' -f1-3 /proc/loadavg)"
done
