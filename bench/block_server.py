"""A timing process driven through a pipe (`benches/fit_predict_timing.rs --serve`,
`bench/peer_serve.py`): it says `ready` once loaded, then answers each request line with one
timed block's median seconds. `bench/python_vs_rust.py` and `bench/ab_timing.py` alternate such
blocks between processes, so that all see the same stretches of a shared machine's load."""
import subprocess
import sys


class Server:
    """A process that answers each request line with one timed block's median seconds."""

    def __init__(self, cmd):
        self.p = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, bufsize=1)
        # Loaded and fitted once: nothing of its start runs beside the others' blocks.
        if self.p.stdout.readline().strip() != "ready":
            sys.exit(f"{cmd[0]} did not start (exit {self.p.wait()})")

    def __call__(self, request):
        self.p.stdin.write(request + "\n")
        self.p.stdin.flush()
        line = self.p.stdout.readline()
        if not line:
            sys.exit(f"{self.p.args[0]} ended on {request!r} (exit {self.p.wait()})")
        return float(line)

    def close(self):
        self.p.stdin.close()
        self.p.wait()
