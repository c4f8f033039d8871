"""The Python package and the command line are one tool: the same data, the same models (byte
for byte), the same estimates, and each reads the other's model files."""

import json
from pathlib import Path

import numpy as np
import pytest

import linpose
from conftest import run

METHODS = {"linear": linpose.LinearPose, "eigenspace": linpose.EigenspacePose, "refined": linpose.RefinedPose}


def test_rendered_in_memory_equals_written(duck, duck_arrays):
    X, y, params, names = linpose.read_dataset(duck)
    Xs, ys, ps = duck_arrays
    assert X.dtype == np.uint8 and X.shape == Xs.shape == (160, 36, 48)
    assert np.array_equal(X, Xs) and np.array_equal(y, ys)
    assert params == ps == [("elevation", None), ("azimuth", 360.0)]
    assert len(names) == 160 and names[0].endswith(".png")


@pytest.mark.parametrize("method", sorted(METHODS))
def test_model_files_are_byte_identical(cli, duck, tmp_path, method):
    cli_model = tmp_path / "cli.safetensors"
    run(cli, "train", "--data", duck, "--train-step", "18", "--method", method, "--out", cli_model)
    X, y, params, _ = linpose.read_dataset(duck)
    train = linpose.train_mask(y, params, 18)
    est = METHODS[method](params=params).fit(X[train], y[train])
    py_model = tmp_path / "py.safetensors"
    assert est.save(py_model) == py_model.stat().st_size
    assert py_model.read_bytes() == cli_model.read_bytes()
    # The same holds from float32 features (the reader's values for 8-bit images).
    est32 = METHODS[method](params=params).fit(X[train].astype(np.float32) / np.float32(255), y[train])
    assert est32.to_bytes() != b"" and est32.predict(X[:1]).shape == (1, 2)


@pytest.mark.parametrize("method", sorted(METHODS))
def test_estimates_agree_with_predict(cli, duck, tmp_path, method):
    """linpose predict on the PNG files and the estimator on the arrays read from them: the same
    poses (the command prints them to 1e-5 and below)."""
    model = tmp_path / "m.safetensors"
    run(cli, "train", "--data", duck, "--train-step", "18", "--method", method, "--out", model)
    out = run(cli, "predict", "--model", model, "--json", duck)
    rows = [json.loads(line) for line in out.stdout.splitlines()]
    by_name = {Path(r["image"]).name: r["pose"] for r in rows}
    X, y, params, names = linpose.read_dataset(duck)
    est = linpose.load(model)
    assert type(est) is METHODS[method] and est.params_ == params
    pred = est.predict(X)
    cli_pred = np.array([[by_name[Path(n).name][p] for p, _ in params] for n in names])
    np.testing.assert_allclose(pred, cli_pred, atol=1e-4)


def test_cli_reads_a_python_model(cli, duck_arrays, tmp_path):
    X, y, params = duck_arrays
    est = linpose.RefinedPose(params=params, bin=1).fit(X[::2], y[::2])
    est.save(tmp_path / "py.safetensors")
    img = tmp_path / "q.png"
    from PIL import Image

    Image.fromarray(X[3]).save(img)
    r = run(cli, "predict", "--model", tmp_path / "py.safetensors", img)
    assert "azimuth" in r.stdout
    cli_pose = [float(t.split("=")[1]) for t in r.stdout.split() if t.startswith(("elevation=", "azimuth="))]
    np.testing.assert_allclose(cli_pose, est.predict(X[3:4])[0], atol=1e-9)
