"""Shared fixtures: the command-line tool (the workspace's release build) and small rendered
data sets, made by the tests themselves."""

import os
import subprocess
from pathlib import Path

import pytest

import linpose

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture(scope="session")
def cli():
    """The `linpose` command: $LINPOSE_CLI, else the workspace's release build."""
    path = os.environ.get("LINPOSE_CLI") or str(ROOT / "target" / "release" / "linpose")
    if not Path(path).exists():
        pytest.fail(f"no linpose command at {path}: run `cargo build --release --bin linpose` first (or set LINPOSE_CLI)")
    return path


def run(cli, *args):
    """Runs the command, failing the test with its messages when it fails."""
    r = subprocess.run([cli, *map(str, args)], capture_output=True, text=True)
    assert r.returncode == 0, f"linpose {' '.join(map(str, args))} failed: {r.stderr}"
    return r


@pytest.fixture(scope="session")
def duck(tmp_path_factory, cli):
    """A small rendered data set on disk (written by `linpose synth`): 40 azimuths x 4
    elevations of 48 x 36."""
    out = tmp_path_factory.mktemp("data") / "duck"
    run(cli, "synth", "--object", "duck", "--out", out, "--azimuth", "0:351:9", "--elevation", "32:59:9", "--size", "48x36")
    return out


@pytest.fixture(scope="session")
def duck_arrays():
    """The same views rendered in memory."""
    return linpose.synth("duck", azimuth="0:351:9", elevation="32:59:9", size=(48, 36))
