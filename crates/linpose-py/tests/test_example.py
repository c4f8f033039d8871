"""The documented example (docs/examples/coil_pose.py) runs as a researcher would run it, on a
COIL-style folder the test writes: 72 views, 5 degrees apart, named objO__K.png."""

import subprocess
import sys

from PIL import Image

import linpose
from conftest import ROOT


def test_coil_example_runs(tmp_path):
    X, y, _ = linpose.synth("pot", azimuth="0:355:5", elevation="40:40:1", size=(64, 64))
    coil = tmp_path / "coil"
    coil.mkdir()
    for k, img in enumerate(X):
        Image.fromarray(img).save(coil / f"obj3__{k}.png")
    r = subprocess.run(
        [sys.executable, str(ROOT / "docs" / "examples" / "coil_pose.py"), str(coil), "--object", "3", "--out", str(tmp_path / "e.png")],
        capture_output=True, text=True, cwd=tmp_path, timeout=600,
    )
    assert r.returncode == 0, r.stderr
    assert "RefinedPose     unseen mean error" in r.stdout and "GridSearchCV: bin=" in r.stdout
    assert (tmp_path / "e.png").stat().st_size > 1000
    assert linpose.load(tmp_path / "refined.safetensors").predict(X[:2]).shape == (2,)


def test_recognition_example_runs(tmp_path):
    coil = tmp_path / "coil"
    coil.mkdir()
    for o, name in enumerate(("duck", "pot", "cap", "column"), start=1):
        X, _, _ = linpose.synth(name, azimuth="0:355:5", elevation="40:40:1", size=(64, 64))
        for k, img in enumerate(X):
            Image.fromarray(img).save(coil / f"obj{o}__{k}.png")
    r = subprocess.run(
        [sys.executable, str(ROOT / "docs" / "examples" / "coil_recognize.py"), str(coil), "--leave-out", "4", "--out", str(tmp_path / "d.png")],
        capture_output=True, text=True, cwd=tmp_path, timeout=600,
    )
    assert r.returncode == 0, r.stderr
    assert "unseen views: " in r.stdout and "obj4, left out: " in r.stdout and "GridSearchCV: recognizer=" in r.stdout
    assert (tmp_path / "d.png").stat().st_size > 1000
    rec = linpose.load(tmp_path / "cell.safetensors")
    assert isinstance(rec, linpose.ObjectRecognizer) and list(rec.classes_) == ["obj1", "obj2", "obj3"]
