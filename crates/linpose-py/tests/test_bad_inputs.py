"""Every bad input is a Python exception with the library's message, never a crash."""

import numpy as np
import pytest
from sklearn.exceptions import NotFittedError

import linpose


@pytest.fixture(scope="module")
def fitted():
    X, y, params = linpose.synth("cap", azimuth="0:350:10", elevation="32:32:1", size=(32, 24))
    return linpose.LinearPose(params=params[1:]).fit(X, y[:, 1]), X, y[:, 1]


def test_not_fitted():
    with pytest.raises(NotFittedError):
        linpose.RefinedPose().predict(np.zeros((1, 4), np.float32))


def test_wrong_image_size(fitted):
    est, X, _ = fitted
    with pytest.raises(ValueError, match="X has 100 features, but LinearPose is expecting 768"):
        est.predict(np.zeros((2, 10, 10), np.uint8))


def test_non_finite_and_wrong_kinds(fitted):
    est, X, y = fitted
    bad = X[:2].astype(np.float32)
    bad[1, 3, 4] = np.nan
    with pytest.raises(ValueError, match="image 1 has a value that is not finite"):
        est.predict(bad)
    with pytest.raises(ValueError):
        est.predict(X[:2].astype(np.complex64))
    with pytest.raises(ValueError):
        est.predict(np.zeros((0, 24, 32), np.uint8))
    with pytest.raises(TypeError):
        linpose._linpose.Model.predict(est.model_, "not an array")


def test_bad_fit_inputs():
    X, y, params = linpose.synth("cap", azimuth="0:350:10", elevation="32:32:1", size=(32, 24))
    with pytest.raises(ValueError, match="params names 2 pose parameters"):
        linpose.LinearPose(params=params).fit(X, y[:, 1])
    with pytest.raises(ValueError, match="image_shape"):
        linpose.LinearPose(image_shape=(5, 5)).fit(X.reshape(len(X), -1), y[:, 1])
    with pytest.raises(ValueError, match="ridge"):
        linpose.LinearPose(ridge="lots").fit(X, y[:, 1])
    with pytest.raises(ValueError, match="period"):
        linpose.LinearPose(params=[("azimuth", -1)]).fit(X, y[:, 1])
    with pytest.raises(ValueError, match="normalize"):
        linpose.LinearPose(normalize="sideways").fit(X, y[:, 1])
    with pytest.raises(ValueError, match="identical"):
        linpose.LinearPose().fit(np.concatenate([X, X[:1]]), np.concatenate([y[:, 1], [5.0]]))
    with pytest.raises(ValueError, match="same training pose"):
        linpose.EigenspacePose().fit(X, np.zeros(len(X)))
    with pytest.raises(ValueError, match="1 sample"):
        linpose.RefinedPose().fit(X[:1], y[:1, 1])
    with pytest.raises(ValueError, match="no image|empty|0 sample"):
        linpose.LinearPose().fit(X[:0], y[:0, 1])


def test_bad_files(tmp_path):
    with pytest.raises(OSError, match="nope.safetensors"):
        linpose.load(tmp_path / "nope.safetensors")
    (tmp_path / "junk.safetensors").write_bytes(b"\x08\x00\x00\x00\x00\x00\x00\x00{}      ")
    with pytest.raises(ValueError, match="junk.safetensors"):
        linpose.load(tmp_path / "junk.safetensors")
    with pytest.raises(ValueError):
        linpose.from_bytes(b"not a model")
    with pytest.raises(ValueError, match="no such folder"):
        linpose.read_dataset(tmp_path / "missing")
    (tmp_path / "set").mkdir()
    (tmp_path / "set" / "poses.csv").write_text("image,azimuth\nmissing.png,0\n")
    with pytest.raises(OSError, match="missing.png"):
        linpose.read_dataset(tmp_path / "set")


def test_bad_synth_arguments():
    with pytest.raises(ValueError, match="unknown|built-in|no such"):
        linpose.synth("no-such-object", azimuth="0:10:5", elevation="32:32:1", size=(8, 8))
    with pytest.raises(ValueError):
        linpose.synth("duck", azimuth="0:10:0", elevation="32:32:1", size=(8, 8))
    with pytest.raises(ValueError, match="give one of"):
        linpose.synth()


def test_non_finite_poses_are_refused():
    X, y, params = linpose.synth("cap", azimuth="0:350:10", elevation="32:32:1", size=(32, 24))
    bad = y[:, 1].copy()
    bad[4] = np.nan
    with pytest.raises(ValueError, match="sample 4 is not finite"):
        linpose.LinearPose().fit(X, bad)


def test_a_failed_refit_leaves_the_estimator_unfitted():
    # The old model is let go before a new fit (its memory free for the new one), so a refit
    # the core refuses leaves no model behind, rather than the old one passing for the new.
    X, y, params = linpose.synth("cap", azimuth="0:350:10", elevation="32:32:1", size=(32, 24))
    est = linpose.LinearPose().fit(X, y[:, 1])
    bad = y[:, 1].copy()
    bad[4] = np.nan
    with pytest.raises(ValueError, match="sample 4 is not finite"):
        est.fit(X, bad)
    with pytest.raises(NotFittedError):
        est.predict(X[:1])
    # Fitted again, it reproduces its training poses (score: minus the mean error, degrees).
    assert est.fit(X, y[:, 1]).score(X, y[:, 1]) > -1e-3


def test_predict_each_answers_every_good_image_and_names_each_bad_one():
    X, y, params = linpose.synth("cap", azimuth="0:350:10", elevation="32:32:1", size=(32, 24))
    est = linpose.EigenspacePose(params=params[1:]).fit(X[::2], y[::2, 1])
    batch = np.concatenate([X[1:3], np.zeros((1,) + X.shape[1:], X.dtype), X[3:5]])
    # predict keeps scikit-learn's semantics: the batch raises, naming the row.
    with pytest.raises(ValueError, match="row 2 of the batch: the image is all black"):
        est.predict(batch)
    pose, refused = est.predict_each(batch)
    assert refused[:2] == [None, None] and refused[3:] == [None, None]
    assert refused[2].startswith("the image is all black")
    assert np.isnan(pose[2]).all()
    good = np.concatenate([X[1:3], X[3:5]])
    np.testing.assert_array_equal(pose[[0, 1, 3, 4]], est.predict(good).reshape(4, -1))
    # A batch with nothing wrong: every image, nothing refused.
    pose, refused = est.predict_each(good)
    assert refused == [None] * 4 and not np.isnan(pose).any()
