"""Builds one of linpose's timing harnesses (crates/linpose/benches/NAME.rs, a `harness = false`
bench target) and returns its executable's path, read from cargo's JSON messages, so that the
scripts find it wherever CARGO_TARGET_DIR puts it.

    from bench_bin import bench_binary
    exe = bench_binary("predict_timing")
"""
import json, os, subprocess

root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def bench_binary(name):
    out = subprocess.run(
        ["cargo", "bench", "--no-run", "--message-format=json", "-p", "linpose", "--bench", name],
        check=True, capture_output=True, text=True, cwd=root,
    ).stdout
    for line in out.splitlines():
        msg = json.loads(line) if line.startswith("{") else {}
        if msg.get("reason") == "compiler-artifact" and msg.get("target", {}).get("name") == name and msg.get("executable"):
            return msg["executable"]
    raise SystemExit(f"cargo built no executable for the bench target {name}")
