#!/usr/bin/env python3
"""CI: the lab leaves the product. Fails (exit 1, naming the problem) when BENCHMARKS.md has 400
lines or more, or when a file in bench/ is named nowhere in BENCHMARKS.md or .ci/run (every
script there makes a current table or runs a check).

    python3 .ci/lab.py
"""
import os, sys

root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MAX_LINES = 400
problems = []

bench_md = open(os.path.join(root, "BENCHMARKS.md"), encoding="utf-8").read()
lines = bench_md.count("\n") + (0 if bench_md.endswith("\n") or not bench_md else 1)
if lines >= MAX_LINES:
    problems.append(f"BENCHMARKS.md has {lines} lines, the limit is under {MAX_LINES}: keep one current table per topic")

ci_run = open(os.path.join(root, ".ci", "run"), encoding="utf-8").read()
bench_dir = os.path.join(root, "bench")
for name in sorted(os.listdir(bench_dir)):
    path = os.path.join(bench_dir, name)
    if not os.path.isfile(path) or name.startswith("."):
        continue
    if name not in bench_md and name not in ci_run:
        problems.append(f"bench/{name} is named nowhere in BENCHMARKS.md or .ci/run: name the table it makes, or remove it")

for p in problems:
    print(f"lab check: {p}", file=sys.stderr)
if problems:
    sys.exit(1)
print(f"lab check: BENCHMARKS.md {lines} lines, every bench/ script named")
