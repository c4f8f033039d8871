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
    # The same holds from float32 features: the reader's values of 8-bit levels, v * fl(1/255).
    features = X[train].astype(np.float32) * (np.float32(1) / np.float32(255))
    assert METHODS[method](params=params).fit(features, y[train]).to_bytes() == cli_model.read_bytes()


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


def test_sixteen_bit_images_are_read_as_features(tmp_path):
    """A data set that is not 8-bit comes back as the reader's float32 features (v / 65535)."""
    from PIL import Image

    levels = np.arange(3 * 4 * 5, dtype=np.uint16).reshape(3, 4, 5) * 1000
    rows = ["image,azimuth"]
    for k, img in enumerate(levels):
        Image.fromarray(img.astype(np.uint16)).save(tmp_path / f"v{k}.png")
        rows.append(f"v{k}.png,{10 * k}")
    (tmp_path / "poses.csv").write_text("\n".join(rows) + "\n")
    X, y, params, names = linpose.read_dataset(tmp_path)
    assert X.dtype == np.float32 and X.shape == (3, 4, 5) and names == ["v0.png", "v1.png", "v2.png"]
    np.testing.assert_array_equal(X, levels.astype(np.float32) * (np.float32(1) / np.float32(65535)))
    assert params == [("azimuth", 360.0)] and y[:, 0].tolist() == [0.0, 10.0, 20.0]


def test_eight_bit_images_come_in_numpys_own_array_unless_a_later_one_is_wider(tmp_path):
    """8-bit images are read into an array numpy allocated (its own in every way); a data set
    whose first image is 8-bit and a later one 16-bit comes back as features, as a 16-bit one."""
    from PIL import Image

    levels = (np.arange(3 * 4 * 5).reshape(3, 4, 5) * 4).astype(np.uint8)
    rows = ["image,azimuth"]
    for k, img in enumerate(levels):
        Image.fromarray(img).save(tmp_path / f"v{k}.png")
        rows.append(f"v{k}.png,{10 * k}")
    (tmp_path / "poses.csv").write_text("\n".join(rows) + "\n")
    X, _, _, _ = linpose.read_dataset(tmp_path)
    assert X.dtype == np.uint8 and X.flags.owndata and X.flags.c_contiguous
    np.testing.assert_array_equal(X, levels)
    Image.fromarray(levels[2].astype(np.uint16) * 257).save(tmp_path / "v2.png")
    X, _, _, _ = linpose.read_dataset(tmp_path)
    assert X.dtype == np.float32
    np.testing.assert_allclose(X, levels / 255.0, rtol=1e-6)


def test_many_object_model_files_are_read_as_recognisers_and_refused_as_one_model(cli, tmp_path):
    for o in ("duck", "cap"):
        run(cli, "synth", "--object", o, "--out", tmp_path / "set" / o, "--azimuth", "0:350:10", "--elevation", "40", "--size", "32x24")
    model = tmp_path / "m.safetensors"
    run(cli, "train", "--data", tmp_path / "set", "--method", "linear", "--out", model)
    assert isinstance(linpose.load(model), linpose.ObjectRecognizer)
    assert isinstance(linpose.from_bytes(model.read_bytes()), linpose.ObjectRecognizer)
    # The one-model reader says what reads it.
    with pytest.raises(ValueError, match="several objects.*in Python `linpose.load` \\(an ObjectRecognizer\\)"):
        linpose._linpose.load(str(model))
    with pytest.raises(ValueError, match="several objects"):
        linpose._linpose.Model.from_bytes(model.read_bytes())
