"""The recogniser from Python: several rendered objects told apart and their poses, objects left
out reported unknown, recognition without poses, the command line's model files both ways, the
labels kept by model files as given, and bad inputs refused by name."""

import json
import pickle
import subprocess

import numpy as np
import PIL.Image
import pytest
from sklearn.base import clone
from sklearn.exceptions import NotFittedError

import linpose
from conftest import run

OBJECTS = ("duck", "pot", "cap")
PARAMS = [("elevation", None), ("azimuth", 360.0)]


@pytest.fixture(scope="module")
def views():
    """Each of the three objects and the twin every 5 degrees of azimuth at elevation 40, 64 x
    48: ``{name: (images, poses)}``."""
    out = {}
    for o in OBJECTS + ("twin",):
        images, poses, params = linpose.synth(o, azimuth="0:355:5", elevation="40", size=(64, 48))
        assert [tuple(p) for p in params] == PARAMS
        out[o] = (images, poses)
    return out


def training(views, names=OBJECTS):
    """Every 10 degrees of each object's views: (X, labels, poses)."""
    X, y, P = [], [], []
    for o in names:
        images, poses = views[o]
        keep = poses[:, 1] % 10 == 0
        X.append(images[keep])
        y += [o] * int(keep.sum())
        P.append(poses[keep])
    return np.concatenate(X), np.array(y), np.concatenate(P)


def unseen(views, o):
    images, poses = views[o]
    keep = poses[:, 1] % 10 != 0
    return images[keep], poses[keep]


def test_objects_are_told_apart_their_poses_estimated_and_an_object_left_out_is_unknown(views):
    X, y, P = training(views)
    est = linpose.ObjectRecognizer(pose=linpose.EigenspacePose(components=12), params=PARAMS).fit(X, y, P)
    assert list(est.classes_) == sorted(OBJECTS) and est.params_ == PARAMS
    # Identity: the training views are recognised as themselves.
    assert (est.predict(X) == y).all()
    for o in OBJECTS:
        images, poses = unseen(views, o)
        assert (est.predict(images) == o).mean() >= 0.97, o
        err = linpose.pose_error(poses, est.predict_pose(images), PARAMS)
        assert np.nanmean(err) < 3.0, (o, np.nanmean(err))
    images, _ = views["twin"]
    label, nearest, distance, confidence = est.recognize(images)
    assert est.unknown_label_ == "unknown" and (label == "unknown").mean() >= 0.95
    assert set(nearest) <= set(OBJECTS) and (distance > 0).all() and ((confidence >= 0) & (confidence <= 1)).all()
    # An image of none of the objects has no pose; the label for it is the user's.
    assert np.isnan(est.predict_pose(images)[label == "unknown"]).all()
    # scikit-learn's scores compare predictions with labels, unknown ones included.
    assert 0.0 <= est.score(np.concatenate([images, X]), np.concatenate([["twin"] * len(images), y])) < 1.0
    named = clone(est).set_params(unknown_label="none").fit(X, y, P)
    assert set(named.predict(images)) <= set(OBJECTS) | {"none"}
    # Without the unknown-object rule every image is one of the objects.
    assert set(clone(est).set_params(unknown=None).fit(X, y, P).predict(images)) <= set(OBJECTS)
    assert est.distances(images).shape == (len(images), 3)
    # predict recognises without running the pose models, to the same answers.
    both = np.concatenate([images, X])
    for a, b in zip(est.model_.recognize(both), est.model_.estimate(both)):
        np.testing.assert_array_equal(a, b)


def test_without_poses_the_objects_are_told_apart_from_their_views_alone_in_any_order(views):
    X, y, _ = training(views)
    est = linpose.ObjectRecognizer().fit(X, y)
    assert est.params_ is None
    order = np.random.default_rng(0).permutation(len(X))
    shuffled = linpose.ObjectRecognizer().fit(X[order], y[order])
    for o in OBJECTS:
        images, _ = unseen(views, o)
        assert (est.predict(images) == o).mean() >= 0.97, o
        assert (shuffled.predict(images) == est.predict(images)).all()
    assert (est.predict(views["twin"][0]) == "unknown").mean() >= 0.95
    with pytest.raises(ValueError, match="fitted without poses"):
        est.predict_pose(X[:1])
    back = linpose.from_bytes(est.to_bytes())
    assert back.params_ is None and (back.predict(X) == est.predict(X)).all()


def test_integer_labels_and_pickling_keep_the_answers(views):
    X, y, P = training(views)
    ids = np.array([OBJECTS.index(o) * 10 for o in y])
    est = linpose.ObjectRecognizer(recognizer="linear").fit(X, ids)
    twin = views["twin"][0]
    pred = est.predict(np.concatenate([X, twin]))
    assert pred.dtype.kind == "i" and set(pred) <= {0, 10, 20, -1}
    back = pickle.loads(pickle.dumps(est))
    assert (back.predict(twin) == est.predict(twin)).all()
    assert list(back.classes_) == [0, 10, 20]
    # The label for none of them is the user's, of the labels' kind and none of them.
    with pytest.raises(ValueError, match="not of the labels' kind"):
        linpose.ObjectRecognizer(unknown_label="none").fit(X, ids)
    with pytest.raises(ValueError, match="one of the objects' labels"):
        linpose.ObjectRecognizer(unknown_label=10).fit(X, ids)
    assert linpose.ObjectRecognizer().fit(X, ids - 1).unknown_label_ == -2


def test_model_files_keep_the_labels_as_they_were_given(views, tmp_path):
    X, y, P = training(views)
    twin = views["twin"][0]
    ids = np.array([OBJECTS.index(o) * 10 + 1 for o in y], dtype=np.int32)
    for labels, unknown in ((ids, None), (ids, -5), (ids.astype(np.float64), None), (y, "none")):
        est = linpose.ObjectRecognizer(unknown_label=unknown).fit(X, labels)
        est.save(tmp_path / "m.safetensors")
        for back in (linpose.load(tmp_path / "m.safetensors"), linpose.from_bytes(est.to_bytes())):
            # Numbers stay numbers of their dtype (so scikit-learn's scores compare them with
            # the labels), and the label for none of them stays the one given.
            assert back.classes_.dtype == est.classes_.dtype and list(back.classes_) == list(est.classes_)
            assert back.unknown_label_ == est.unknown_label_ and back.unknown_label == unknown
            pred = back.predict(np.concatenate([X, twin]))
            assert (pred == est.predict(np.concatenate([X, twin]))).all()
            # One dtype whether or not an image is unknown.
            assert pred.dtype == back.predict(X).dtype == est.predict(twin).dtype
            assert back.score(X, labels) == 1.0
    # Text labels with the default label for none of them are the names: the file says nothing
    # more (it is the command line's file).
    assert linpose._linpose.Objects.from_bytes(linpose.ObjectRecognizer().fit(X, y).to_bytes()).labels_json is None


def test_model_files_are_the_command_lines_both_ways(views, cli, tmp_path):
    for o in OBJECTS:
        run(cli, "synth", "--object", o, "--out", tmp_path / "set" / o, "--azimuth", "0:350:10", "--elevation", "40", "--size", "64x48")
    model = tmp_path / "cli.safetensors"
    run(cli, "train", "--data", tmp_path / "set", "--method", "linear", "--out", model)
    est = linpose.load(model)
    assert isinstance(est, linpose.ObjectRecognizer) and list(est.classes_) == sorted(OBJECTS)
    assert isinstance(est.pose, linpose.LinearPose) and est.params_ == PARAMS
    # Fitted here on the same images (as the command line reads them), the same file.
    X, y, P = [], [], []
    for o in sorted(OBJECTS):
        images, poses, params, _ = linpose.read_dataset(tmp_path / "set" / o)
        X.append(images)
        y += [o] * len(images)
        P.append(poses)
    mine = linpose.ObjectRecognizer(params=[tuple(p) for p in params]).fit(np.concatenate(X), np.array(y), np.concatenate(P))
    assert mine.to_bytes() == model.read_bytes()
    # The command line's answers are the estimator's, for a file written here too.
    images, poses = unseen(views, "pot")
    files = []
    for i in range(4):
        f = tmp_path / f"q{i}.png"
        PIL.Image.fromarray(images[i]).save(f)
        files.append(f)
    saved = tmp_path / "py.safetensors"
    mine.save(saved)
    out = subprocess.run([cli, "predict", "--model", saved, "--json", *files], capture_output=True, text=True, check=True).stdout
    rows = [json.loads(line) for line in out.splitlines()]
    assert [r["object"] for r in rows] == list(mine.predict(images[:4]))
    got = np.array([[r["pose"]["elevation"], r["pose"]["azimuth"]] for r in rows])
    np.testing.assert_allclose(got, mine.predict_pose(images[:4]), atol=1e-9)


def test_bad_inputs_are_refused_by_name(views):
    X, y, P = training(views)
    with pytest.raises(NotFittedError):
        linpose.ObjectRecognizer().predict(X[:1])
    with pytest.raises(ValueError, match="poses has shape"):
        linpose.ObjectRecognizer().fit(X, y, P[:-1])
    with pytest.raises(ValueError, match="set params on the ObjectRecognizer"):
        linpose.ObjectRecognizer(pose=linpose.LinearPose(params=PARAMS)).fit(X, y, P)
    with pytest.raises(TypeError, match="pose must be"):
        linpose.ObjectRecognizer(pose="refined").fit(X, y, P)
    with pytest.raises(ValueError, match="unknown="):
        linpose.ObjectRecognizer(unknown="maybe").fit(X, y)
    with pytest.raises(ValueError, match="known recognisers"):
        linpose.ObjectRecognizer(recognizer="svm").fit(X, y)
    with pytest.raises(ValueError, match="Unknown label type"):
        linpose.ObjectRecognizer().fit(X, np.linspace(0, 1, len(X)))
    est = linpose.ObjectRecognizer().fit(X, y)
    with pytest.raises(ValueError, match="features"):
        est.predict(X[:, :10, :10])
    black = np.zeros_like(X)
    with pytest.raises(ValueError, match="all black"):
        linpose.ObjectRecognizer().fit(black, y)


def test_a_model_without_poses_serves_the_command_line(views, cli, tmp_path):
    for o in OBJECTS:
        run(cli, "synth", "--object", o, "--out", tmp_path / "set" / o, "--azimuth", "0:355:5", "--elevation", "40", "--size", "64x48")
    X, y = [], []
    for o in OBJECTS:
        images, poses, _, _ = linpose.read_dataset(tmp_path / "set" / o)
        keep = poses[:, 1] % 10 == 0
        X.append(images[keep])
        y += [o] * int(keep.sum())
    est = linpose.ObjectRecognizer().fit(np.concatenate(X), np.array(y))
    model = tmp_path / "views.safetensors"
    est.save(model)
    # predict: each image's object, no pose.
    files = sorted((tmp_path / "set" / "cap").glob("*.png"))[:3]
    out = subprocess.run([cli, "predict", "--model", model, "--json", *files], capture_output=True, text=True, check=True).stdout
    rows = [json.loads(line) for line in out.splitlines()]
    assert [r["object"] for r in rows] == ["cap"] * 3 and all(r["pose"] is None for r in rows)
    # eval: recognition, every view counted as unseen (the model cannot tell its training
    # views), and no pose error.
    r = subprocess.run([cli, "eval", "--model", model, "--data", tmp_path / "set", "--json", tmp_path / "e.json"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "fitted without poses" in r.stderr
    e = json.loads((tmp_path / "e.json").read_text())
    assert e["method"] == "none" and e["recognition"]["unseen"] == 1.0 and e["recognition"]["n_unseen"] == 216
    assert all(s["pose"] is None and s["error_deg"] is None for s in e["samples"])


def test_behind_one_normalisation_stage_moved_views_are_recognised_and_an_empty_one_named(views):
    X, y, P = training(views)
    plain = linpose.ObjectRecognizer(params=PARAMS).fit(X, y, P)
    est = linpose.ObjectRecognizer(params=PARAMS, normalize="geometry").fit(X, y, P)
    assert est.get_params()["normalize"] == "geometry"
    moved, truth = [], []
    for o in OBJECTS:
        images, _ = unseen(views, o)
        moved.append(np.roll(images, (3, -2), axis=(1, 2)))
        truth += [o] * len(images)
    moved, truth = np.concatenate(moved), np.array(truth)
    assert (est.predict(moved) == truth).mean() >= 0.97
    assert (plain.predict(moved) == truth).mean() < 0.9
    back = linpose.from_bytes(est.to_bytes())
    assert back.normalize == "geometry" and (back.predict(moved) == est.predict(moved)).all()
    black = np.concatenate([moved[:2], np.zeros_like(moved[:1])])
    with pytest.raises(ValueError, match="query row 2 of the batch.*no object found"):
        est.predict(black)
