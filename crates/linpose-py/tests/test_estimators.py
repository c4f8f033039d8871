"""The estimators as a scikit-learn user meets them: fitting, estimating, scoring, cloning,
pickling, searching, and the library's identities (training views reproduced)."""

import pickle

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.model_selection import GridSearchCV, KFold

import linpose

ESTIMATORS = [linpose.LinearPose, linpose.EigenspacePose, linpose.RefinedPose]


@pytest.fixture(scope="module")
def turntable():
    """One elevation, 120 azimuths of a rendered duck: trained every 9 degrees."""
    X, y, params = linpose.synth("duck", azimuth="0:357:3", elevation="32:32:1", size=(64, 48))
    return X, y[:, 1], params[1:]


@pytest.mark.parametrize("cls", ESTIMATORS)
def test_fit_predict_score(cls, turntable):
    X, y, params = turntable
    train = linpose.train_mask(y, params, 9)
    est = cls(params=params).fit(X[train], y[train])
    assert est.n_features_in_ == 64 * 48 and est.image_shape_ == (48, 64)
    # The fit sets these from its inputs; the model holds the same.
    m = est.model_
    assert (est.image_shape_, est.params_, est.n_features_in_) == (tuple(m.image_shape), [tuple(p) for p in m.params], m.n_features)
    pred = est.predict(X)
    assert pred.shape == y.shape
    # Training views are reproduced (the linear model exactly fits them; the manifolds pass
    # through them).
    err = linpose.pose_error(y[train], pred[train], params)
    assert err.max() < 0.3, err.max()
    # score is minus the mean pose error, the measure of linpose eval.
    unseen = -est.score(X[~train], y[~train])
    assert 0 < unseen < 3, unseen
    assert np.isclose(-unseen, -np.mean(linpose.pose_error(y[~train], pred[~train], params)))
    # Rows or images, uint8 or the reader's float32: one answer.
    flat = X.reshape(len(X), -1)
    np.testing.assert_allclose(est.predict(flat[:5]), pred[:5])
    np.testing.assert_allclose(est.predict(X[:5].astype(np.float32) / np.float32(255)), pred[:5], atol=1e-3)


def test_the_core_reads_images_as_rows(turntable):
    """The core reads (n, h, w) arrays as rows of h w values, in place or strided (in their
    logical order); arrays of another rank are a TypeError."""
    X, y, params = turntable
    est = linpose.LinearPose(params=params).fit(X[::3], y[::3])
    m = est.model_
    np.testing.assert_array_equal(m.predict(X), m.predict(X.reshape(len(X), -1)))
    flipped = (X.astype(np.float32) / np.float32(255))[:, ::-1, :]
    assert not flipped.flags.c_contiguous
    want = m.predict(np.ascontiguousarray(flipped).reshape(len(X), -1))
    np.testing.assert_array_equal(m.predict(flipped), want)
    np.testing.assert_array_equal(est.predict(flipped), want[:, 0])
    for bad in (X[0].reshape(-1), X[None]):
        with pytest.raises(TypeError, match="2-D or 3-D"):
            m.predict(bad)


@pytest.mark.parametrize("y_2d", [False, True])
def test_predict_in_one_call_answers_as_the_checked_path(y_2d, turntable):
    """An array the core reads as it is goes to the core in one call (``_linpose.Serve``), with
    the estimator's checks and shapes; other inputs take scikit-learn's validation; the answers
    are the same. The first predict after a fit, a pickling or a load makes it; a model fitted on
    named features has none."""
    X, y, params = turntable
    yy = y[:, None] if y_2d else y
    est = linpose.EigenspacePose(params=params).fit(X[::3], yy[::3])
    want = est.model_.predict(X.reshape(len(X), -1))
    want = want if y_2d else want[:, 0]
    for q in (X, X.reshape(len(X), -1), X.astype(np.float64) / 255, list(X.reshape(len(X), -1).astype(np.int64))):
        got = est.predict(q)
        assert got.shape == want.shape
        np.testing.assert_allclose(got, want, atol=1e-9)
    serve = est._serve[0]
    assert serve(list(X[:2])) is None and serve(X[:0]) is None
    with pytest.raises(ValueError, match="X has 3071 features, but EigenspacePose is expecting 3072 features as input"):
        est.predict(X.reshape(len(X), -1)[:, 1:])
    for back in (pickle.loads(pickle.dumps(est)), linpose.from_bytes(est.to_bytes())):
        # (A model file keeps no record of y's shape: one parameter loads as 1-D.)
        full = est.model_.predict(X)
        np.testing.assert_array_equal(back.predict(X), full[:, 0] if back._y_1d else full)
        # Made by the first predict.
        assert back._serve[0]
    pd = pytest.importorskip("pandas")
    frame = pd.DataFrame(X[::3].reshape(40, -1), columns=[f"p{i}" for i in range(64 * 48)])
    named = linpose.EigenspacePose(params=params, image_shape=(48, 64)).fit(frame, yy[::3])
    named.predict(frame)
    assert named._serve == [False]


def test_coef_is_the_papers_figure(turntable):
    X, y, params = turntable
    est = linpose.LinearPose(params=params).fit(X[::3], y[::3])
    assert est.coef_.shape == (2, 64 * 48)  # cos and sin of the azimuth
    assert est.coef_[0].reshape(est.image_shape_).shape == (48, 64)
    enc = est.coef_ @ (X[::3].reshape(40, -1).astype(np.float64) / 255).T + est.intercept_[:, None]
    back = np.degrees(np.arctan2(enc[1], enc[0]))
    assert linpose.pose_error(y[::3], back, params).max() < 1e-3


@pytest.mark.parametrize("cls", ESTIMATORS)
def test_clone_pickle_and_model_bytes(cls, turntable):
    X, y, params = turntable
    est = cls(params=params).fit(X[::3], y[::3])
    c = clone(est)
    assert c.get_params() == est.get_params() and not hasattr(c, "model_")
    back = pickle.loads(pickle.dumps(est))
    np.testing.assert_array_equal(back.predict(X), est.predict(X))
    again = linpose.from_bytes(est.to_bytes())
    assert type(again) is cls and again.to_bytes() == est.to_bytes()
    # The parameters read back from the model refit the same model.
    assert clone(again).set_params(params=params).fit(X[::3], y[::3]).to_bytes() == est.to_bytes()


def test_hypotheses_and_confidence(turntable):
    X, y, params = turntable
    est = linpose.RefinedPose(params=params).fit(X[::3], y[::3])
    pose, conf, hyp, scores = est.predict_hypotheses(X[:4], top=3)
    assert pose.shape == (4, 1) and conf.shape == (4,) and hyp.shape == (4, 3, 1) and scores.shape == (4, 3)
    np.testing.assert_array_equal(hyp[:, 0], pose)
    assert ((conf >= 0) & (conf <= 1)).all()
    assert (np.nansum(scores, axis=1) <= 1 + 1e-9).all()
    # Views moved 5 pixels sideways, unlike every training view: none of the poses explains them,
    # so every score is near 0 (the rest is the chance that they are none of the model's views).
    moved = np.zeros_like(X[:4])
    moved[:, :, 5:] = X[:4, :, :-5]
    _, conf, _, scores = est.predict_hypotheses(moved, top=3)
    assert (conf < 0.01).all() and (np.nansum(scores, axis=1) < 0.01).all(), (conf, scores)


def test_grid_search_over_a_parameter(turntable):
    X, y, params = turntable
    search = GridSearchCV(linpose.RefinedPose(params=params), {"bin": [1, 2]}, cv=KFold(3, shuffle=True, random_state=0))
    search.fit(X, y)
    assert search.best_params_["bin"] in (1, 2) and search.best_score_ > -5


def test_two_parameters_default_names():
    X, y, params = linpose.synth("pot", azimuth="0:350:10", elevation="32:68:12", size=(40, 30))
    est = linpose.EigenspacePose().fit(X, y)
    assert est.params_ == [("elevation", None), ("azimuth", 360.0)] == [tuple(p) for p in est.model_.params]
    flat = linpose.EigenspacePose(image_shape=(30, 40)).fit(X.reshape(len(X), -1), y)
    assert flat.image_shape_ == (30, 40) == tuple(flat.model_.image_shape)
    assert est.predict(X[:3]).shape == (3, 2)


def test_normalize_stage_is_kept(turntable, tmp_path):
    X, y, params = turntable
    est = linpose.LinearPose(params=params, normalize="geometry").fit(X[::3], y[::3])
    est.save(tmp_path / "n.safetensors")
    back = linpose.load(tmp_path / "n.safetensors")
    assert back.normalize == "geometry"
    np.testing.assert_array_equal(back.predict(X[:7]), est.predict(X[:7]))


def test_normalize_is_chosen_on_held_out_views_by_default(turntable, tmp_path):
    X, y, params = turntable
    est = linpose.RefinedPose(params=params).fit(X[::3], y[::3])
    assert est.get_params()["normalize"] == "auto"
    c = est.stage_choice_
    assert c["rule"] == "auto" and c["chosen"] in ("off", "brightness", "geometry", "all")
    assert [s["stage"] for s in c["scores"]] == ["off", "brightness", "geometry", "all"]
    assert c["held_out_views"] > 0 and c["noise_levels"] == [0.05, 0.1]
    # The chosen one is the simplest within three standard errors of the best (MARGIN).
    best = min((s for s in c["scores"] if s.get("pooled_deg") is not None), key=lambda s: s["pooled_deg"])
    bound = best["pooled_deg"] + 3 * best["standard_error"]
    assert next(s["stage"] for s in c["scores"] if s.get("pooled_deg") is not None and s["pooled_deg"] <= bound) == c["chosen"]
    # The model file keeps the rule, so a loaded estimator refits as it was fitted.
    est.save(tmp_path / "a.safetensors")
    back = linpose.load(tmp_path / "a.safetensors")
    assert back.normalize == "auto" and back.stage_choice_ == c
    # Off, as asked: no stage, and the record says so.
    off = linpose.RefinedPose(params=params, normalize="off").fit(X[::3], y[::3])
    assert off.stage_choice_["rule"] == "off" and off.model_.normalize_json is None
    assert linpose.RefinedPose(params=params, normalize=None).fit(X[::3], y[::3]).stage_choice_["chosen"] == "off"


def test_docstring_examples_run():
    import doctest

    import linpose._estimators

    result = doctest.testmod(linpose._estimators)
    assert result.attempted > 0 and result.failed == 0
