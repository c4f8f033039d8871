"""The documented examples (docs/examples/coil_pose.py and coil_recognize.py) run as a researcher
would run them, on a COIL-style folder the test writes: 72 views, 5 degrees apart, named
objO__K.png."""

import subprocess
import sys

from PIL import Image

import linpose
from conftest import ROOT


def coil_folder(tmp_path, objects):
    """The built-in objects `objects` rendered as COIL objects 1, 2, ...: the folder and each
    object's images."""
    coil = tmp_path / "coil"
    coil.mkdir()
    images = []
    for o, name in enumerate(objects, start=1):
        X, _, _ = linpose.synth(name, azimuth="0:355:5", elevation="40:40:1", size=(64, 64))
        for k, img in enumerate(X):
            Image.fromarray(img).save(coil / f"obj{o}__{k}.png")
        images.append(X)
    return coil, images


def run_example(tmp_path, script, *args):
    """Runs the example in `tmp_path`, failing with its messages if it fails; its output."""
    r = subprocess.run(
        [sys.executable, str(ROOT / "docs" / "examples" / script), *map(str, args)], capture_output=True, text=True, cwd=tmp_path, timeout=600
    )
    assert r.returncode == 0, r.stderr
    return r.stdout


def test_coil_example_runs(tmp_path):
    coil, (X,) = coil_folder(tmp_path, ["pot"])
    out = run_example(tmp_path, "coil_pose.py", coil, "--object", "1", "--out", tmp_path / "e.png")
    assert "RefinedPose     unseen mean error" in out and "GridSearchCV: bin=" in out
    assert (tmp_path / "e.png").stat().st_size > 1000
    assert linpose.load(tmp_path / "refined.safetensors").predict(X[:2]).shape == (2,)


def test_recognition_example_runs(tmp_path):
    coil, _ = coil_folder(tmp_path, ["duck", "pot", "cap", "column"])
    out = run_example(tmp_path, "coil_recognize.py", coil, "--leave-out", "4", "--out", tmp_path / "d.png")
    assert "unseen views: " in out and "obj4, left out: " in out and "GridSearchCV: recognizer=" in out
    assert (tmp_path / "d.png").stat().st_size > 1000
    rec = linpose.load(tmp_path / "cell.safetensors")
    assert isinstance(rec, linpose.ObjectRecognizer) and list(rec.classes_) == ["obj1", "obj2", "obj3"]
