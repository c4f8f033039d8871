"""The estimators: one per method, with scikit-learn's API.

Each wraps a fitted model of the Rust library (``model_``). Images are a numpy array of shape
``(n, h, w)``, or ``(n, pixels)`` with ``image_shape=(h, w)`` (without it, each row is an image
of one row). ``uint8`` and ``uint16`` values are image levels (the feature is v / 255 or
v / 65535, as when linpose reads an image file); floats are features as they are. Poses are
degrees, ``(n, K)`` or ``(n,)`` for one parameter; ``predict`` returns the shape ``fit`` saw.
"""

from __future__ import annotations

import json
from typing import Any, Optional, Sequence, Tuple, Union

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.utils.validation import validate_data

from . import _linpose
from ._core import _DTYPES, _FAST, CoreModel, _flatten

ParamSpec = Union[str, Tuple[str, Optional[float]]]

def resolve_params(params: Optional[Sequence[ParamSpec]], k: int) -> list:
    """The pose parameters as ``(name, period)`` pairs for poses of ``k`` values.

    ``params`` lists each parameter as a name (``"azimuth"`` is circular with period 360, every
    other name linear, as on the command line) or a ``(name, period)`` pair (period ``None``:
    linear). Without it: ``azimuth`` for one value, ``elevation, azimuth`` for two, ``p0, p1,
    ...`` (linear) for more.
    """
    if params is None:
        names = {1: ["azimuth"], 2: ["elevation", "azimuth"]}.get(k, [f"p{i}" for i in range(k)])
        params = names
    out = []
    for p in params:
        if isinstance(p, str):
            out.append((p, 360.0 if p == "azimuth" else None))
        else:
            try:
                name, period = p
            except (TypeError, ValueError):
                raise ValueError(f"params: {p!r} is neither a name nor a (name, period) pair") from None
            out.append((str(name), None if period is None else float(period)))
    if len(out) != k:
        raise ValueError(f"params names {len(out)} pose parameters ({', '.join(n for n, _ in out)}) but y has {k} columns")
    return out


class PoseEstimator(CoreModel, RegressorMixin, BaseEstimator):
    """What the three estimators share: fit, predict, score, model files and pickling."""

    _method = ""
    _core = _linpose.Model

    def _settings(self) -> list:
        """The method's settings by name, as the command line's flags give them."""
        raise NotImplementedError

    # -- fitting -------------------------------------------------------------------------------

    def fit(self, X, y):
        """Fits the model on images ``X`` at poses ``y`` (degrees).

        Parameters
        ----------
        X : array of shape (n, h, w) or (n, pixels)
            Training images. ``uint8``/``uint16`` are image levels, floats are features.
        y : array of shape (n, K) or (n,)
            Their poses in degrees, one column per pose parameter (see ``params``).

        Returns
        -------
        self
        """
        X, shape = _flatten(X, self.image_shape)
        fast = type(X) is np.ndarray and X.dtype in _FAST and X.ndim == 2 and X.shape[0] > 0 and X.shape[1] > 0
        if fast and type(y) is np.ndarray and y.dtype.kind in "iuf" and y.ndim in (1, 2) and len(y) == len(X) and y.size > 0:
            # Arrays the core reads as they are: scikit-learn's validation would cost a good share
            # of a small fit; the core refuses non-finite values and bad shapes itself.
            self.__dict__.pop("feature_names_in_", None)
            self.n_features_in_ = X.shape[1]
            X = np.ascontiguousarray(X)
        else:
            X, y = validate_data(self, X, y, dtype=_DTYPES, multi_output=True, y_numeric=True, order="C")
        y = np.asarray(y, dtype=np.float64)
        y_1d = y.ndim == 1
        y2 = y.reshape(-1, 1) if y_1d else y
        n, m = X.shape
        if shape is None:
            shape = (1, m)
        if shape[0] * shape[1] != m:
            raise ValueError(f"image_shape {shape} has {shape[0] * shape[1]} pixels but X has {m} values per image")
        self._check_size(n, m)
        params = resolve_params(self.params, y2.shape[1])
        settings = self._settings()
        self._release()
        model = _linpose.fit(self._method, settings, (X, shape[0], shape[1]), np.ascontiguousarray(y2), params, (self.normalize, bool(self.robust)))
        # What the model was fitted with, as the model holds it (its getters give the same values):
        # after a fit the interpreter's own data is out of the cache, and reading back through
        # the getters cost about 8 us of a 0.6 ms fit.
        self._set_fitted(model, y_1d, shape, params, m)
        return self

    def _check_size(self, n: int, m: int) -> None:
        """Refuses training sets the method cannot fit, in scikit-learn's words."""

    def _set_fitted(self, model: Any, y_1d: bool, image_shape: Tuple[int, int], params: list, n_features: int) -> None:
        """The fitted attributes: the model and what it holds (image size, pose parameters,
        features per image)."""
        self.model_ = model
        self.image_shape_ = image_shape
        self.params_ = params
        self.n_features_in_ = n_features
        self._y_1d = y_1d
        self._serve = [None]

    @property
    def stage_choice_(self) -> dict:
        """How the normalisation was decided: the rule (``"auto"`` or the choice given), the
        choice, and with ``"auto"`` every candidate's score on the held-out training views."""
        model = self.__dict__.get("model_")
        if model is None:
            raise AttributeError("stage_choice_: the estimator is not fitted")
        c = model.stage_choice_json
        return json.loads(c) if c is not None else {"rule": _stage(model), "chosen": _stage(model), "scores": []}

    def _serving(self) -> Any:
        """The core's one-call predict for arrays it reads as they are (``_linpose.Serve``), or
        ``False`` where scikit-learn must see every input (a model fitted on named features).

        The first ``predict`` after a fit (or an unpickling) makes it, into the cell
        ``_serve`` that ``fit`` leaves empty, so that ``predict`` changes no attribute: just
        after a fit the interpreter's own data is out of the cache, and making it there cost
        about 22 us of COIL-20 object 1's 1.3 ms linear fit (timed inside ``fit``)."""
        if "feature_names_in_" in self.__dict__:
            return False
        return _linpose.Serve(self.model_, self.n_features_in_, self._y_1d, type(self).__name__)

    def __setstate__(self, state):
        super().__setstate__(state)
        if "model_" in self.__dict__:
            self._serve = [None]

    # -- estimating ----------------------------------------------------------------------------

    def predict(self, X):
        """The pose of each image, degrees: (n, K), or (n,) when fitted on a 1-D ``y``.

        Circular parameters come back within one period from 0 (``[0, period)``).
        """
        # An array the core reads as it is, in one call into the core (checked there as below);
        # anything else as scikit-learn validates it.
        cell = self.__dict__.get("_serve")
        if cell is not None:
            if cell[0] is None:
                cell[0] = self._serving()
            if cell[0]:
                out = cell[0](X)
                if out is not None:
                    return out
        model = self._model()
        out = model.predict(self._rows(X))
        return out[:, 0] if self._y_1d else out

    def predict_each(self, X):
        """The pose of each image that can be estimated, and why each other one cannot: for
        batches that may hold bad frames (an all-black image cannot be scaled to unit energy),
        where ``predict`` raises for the whole batch as scikit-learn expects.

        Returns ``(pose, refused)``: ``pose`` as ``predict`` (always (n, K)), a row of NaN for
        an image with no estimate; ``refused`` a list of n entries, None for an estimated
        image, else the reason. The estimated images get the numbers ``predict`` gives them in
        a batch without the others (an image's estimate does not depend on its batch).
        """
        model = self._model()
        rows = self._rows(X)
        try:
            return model.predict(rows), [None] * len(rows)
        except ValueError:
            pass
        refused = []
        for i in range(len(rows)):
            try:
                model.predict(rows[i : i + 1])
                refused.append(None)
            except ValueError as e:
                refused.append(_reason(str(e)))
        good = [i for i, r in enumerate(refused) if r is None]
        pose = np.full((len(rows), len(self.params_)), np.nan)
        if good:
            pose[good] = model.predict(rows[good])
        return pose, refused

    def predict_hypotheses(self, X, top: int = 3):
        """The estimate of each image with its ranked hypotheses and a confidence.

        Returns ``(pose, confidence, hypotheses, scores)``: ``pose`` as ``predict`` (but always
        (n, K)), ``confidence`` (n,) in [0, 1] (how likely the estimate is within 20 degrees
        of the truth, as judged from the training views), ``hypotheses`` (n, top, K) best first
        and ``scores`` (n, top), padded with NaN where fewer distinct poses were found. The
        eigenspace's and the refined method's scores add up to less than 1 where the image may be
        none of the views the model knows (farther from its manifold than a held-out training
        view): then every score, the confidence too, is near 0.
        """
        return self._model().estimate(self._rows(X), int(top))

    def score(self, X, y, sample_weight=None):
        """Minus the mean pose error in degrees (the angle on the viewing sphere between the
        true and the estimated pose, as ``linpose eval``): higher is better, 0 is perfect."""
        model = self._model()
        pred = model.predict(self._rows(X))
        y = np.asarray(y, dtype=np.float64).reshape(pred.shape[0], -1)
        err = _linpose.pose_error(np.ascontiguousarray(y), pred, self.params_)
        return -float(np.average(err, weights=sample_weight))

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.target_tags.multi_output = True
        tags.target_tags.single_output = True
        # score is minus an angle in degrees, not an R^2: scikit-learn's "> 0.5" does not apply.
        tags.regressor_tags.poor_score = True
        tags.input_tags.allow_nan = False
        return tags

class LinearPose(PoseEstimator):
    """Okatani & Deguchi's linear model: each pose parameter a linear function of the pixels.

    Circular parameters are estimated as (cos, sin) pairs; the fit is the minimum-norm exact
    solution through the N x N Gram matrix of the training images (MVA 2000), optionally
    ridge-regularised.

    Parameters
    ----------
    ridge : float or "auto", default=0.0
        Ridge lambda added to the Gram matrix (0: the paper's exact minimum-norm fit), or
        "auto": the lambda with the smallest exact leave-one-out error.
    noise_level : float or "auto", default=None
        Train for query noise of +-A (a fraction of full brightness): lambda = N A^2 / 3; "auto"
        estimates the noise of the training images. Not with ``ridge``.
    center : bool, default=False
        Subtract the mean image and pose first (an intercept; the paper has none).
    params : list of names or (name, period) pairs, default=None
        The pose parameters, one per column of ``y``: ``"azimuth"`` is circular (360), other
        names linear; ``("roll", 360)`` makes any circular. Default: ``azimuth`` for one
        column, ``elevation, azimuth`` for two.
    image_shape : (h, w), default=None
        The image size when ``X`` is given as rows; (n, h, w) arrays carry it.
    normalize : {"auto", "off", None, "all", "geometry", "brightness"}, default="auto"
        The normalisation stage: find the object in every image and centre it, scale it to a
        fixed size and/or bring it to a fixed brightness before the model sees it (stored in the
        model; queries too). ``"auto"`` chooses among off, brightness, geometry and all on
        held-out training views, as ``linpose train`` does (``stage_choice_`` says what it
        chose); ``"off"`` or ``None`` uses the images as they are; the others force it.
    robust : bool, default=False
        The robust stage (``linpose train --robust``; gray images): a query the training images'
        eigenspace does not explain (a cluttered background, an occluder) has the pixels it
        cannot explain found and replaced by the robust reconstruction before the model sees
        it; a query it explains goes as it is, with the answer it gets without the stage.

    Attributes
    ----------
    model_ : linpose._linpose.Model
        The fitted model (the Rust library's).
    coef_ : ndarray of shape (K_enc, h * w)
        The weights: one row per encoded output ((cos, sin) rows for a circular parameter,
        one row for a linear one), so ``coef_[j].reshape(image_shape_)`` is the paper's Fig. 2.
    intercept_ : ndarray of shape (K_enc,)
        The bias of each encoded output (0 without ``center``).
    params_ : list of (name, period)
        The pose parameters.
    image_shape_ : (h, w)
        The image size.
    n_features_in_ : int
        Features per image (h * w).
    stage_choice_ : dict
        How the normalisation was decided (``normalize``): the rule, the choice, and each
        candidate's held-out score.

    Examples
    --------
    >>> import linpose
    >>> X, y, params = linpose.synth("duck", azimuth="0:357:3", elevation="32:32:1", size=(40, 30))
    >>> model = linpose.LinearPose(params=params).fit(X[::3], y[::3])
    >>> round(-model.score(X, y), 1) < 5
    True
    """

    _method = "linear"

    def __init__(self, *, ridge=0.0, noise_level=None, center=False, params=None, image_shape=None, normalize="auto", robust=False):
        self.ridge = ridge
        self.noise_level = noise_level
        self.center = center
        self.params = params
        self.image_shape = image_shape
        self.normalize = normalize
        self.robust = robust

    def _settings(self):
        s = []
        if self.noise_level is not None:
            s.append(("noise-level", str(self.noise_level)))
            if self.ridge not in (0, 0.0):
                s.append(("ridge", _number(self.ridge)))
        else:
            s.append(("ridge", _number(self.ridge)))
        if self.center:
            s.append(("center", "true"))
        return s

    @staticmethod
    def _given(p: dict) -> dict:
        rule = p.get("rule", "fixed")
        out = {"center": bool(p.get("center", False)), "ridge": float(p.get("ridge", 0.0)), "noise_level": None}
        if rule == "loo":
            out["ridge"] = "auto"
        elif rule == "noise_auto":
            out["noise_level"] = "auto"
        elif isinstance(rule, dict) and "noise" in rule:
            out["noise_level"] = float(rule["noise"])
        return out

    @property
    def coef_(self):
        """The weights (K_enc, h * w), read from the fitted model."""
        model = self.__dict__.get("model_")
        if model is None:
            raise AttributeError("coef_: the estimator is not fitted")
        return model.coefficients

    @property
    def intercept_(self):
        """The bias of each encoded output (K_enc,), read from the fitted model."""
        model = self.__dict__.get("model_")
        if model is None:
            raise AttributeError("intercept_: the estimator is not fitted")
        return next(np.asarray(v) for name, _shape, v in model.tensors() if name == "bias")


class EigenspacePose(PoseEstimator):
    """Murase & Nayar's parametric eigenspace, the method the paper measures itself against.

    Images scaled to unit energy are projected on the first L eigenimages of the training set;
    the training views' points, interpolated by a cubic spline along each pose axis and
    resampled every ``manifold_step`` degrees, form the appearance manifold, and a query's pose
    is that of the nearest manifold point. The training poses must form a full grid.

    Parameters
    ----------
    components : int, default=20
        Number of eigenimages L (capped at N - 1).
    energy : float, default=None
        Instead of ``components``: the fewest eigenimages holding this fraction of the energy.
    manifold_step : float, default=0.5
        Resample the manifold every this many degrees along each pose axis.
    params, image_shape, normalize, robust
        As for :class:`LinearPose`.

    Attributes
    ----------
    model_, params_, image_shape_, n_features_in_
        As for :class:`LinearPose`.
    """

    _method = "eigenspace"

    def __init__(self, *, components=20, energy=None, manifold_step=0.5, params=None, image_shape=None, normalize="auto", robust=False):
        self.components = components
        self.energy = energy
        self.manifold_step = manifold_step
        self.params = params
        self.image_shape = image_shape
        self.normalize = normalize
        self.robust = robust

    def _settings(self):
        s = [("manifold-step", _number(self.manifold_step))]
        if self.energy is not None:
            s.append(("energy", _number(self.energy)))
        else:
            s.append(("components", _integer(self.components, "components")))
        return s

    @staticmethod
    def _given(p: dict) -> dict:
        dim = p.get("dimension", {})
        out = {"manifold_step": float(p.get("manifold_step", 0.5))}
        if "energy" in dim:
            out["energy"] = float(dim["energy"])
        elif "fixed" in dim:
            out["components"] = int(dim["fixed"])
        return out

    def _check_size(self, n, m):
        _at_least_two(self, n, m)


class RefinedPose(PoseEstimator):
    """linpose's refined eigenspace: the eigenspace's manifold kept as a surface and searched
    exactly, noisy images detected and matched apart, every setting chosen on held-out
    training views unless given. The training poses must form a full grid.

    Parameters
    ----------
    components : int or "auto", default="auto"
        Number of eigenimages L, or chosen from held-out training views.
    resolution : float, default=0.5
        Report poses on a lattice of this many degrees (0: the continuous estimate).
    bin : int or "auto", default="auto"
        Bin the images by B (each pixel the mean of a B x B block) before fitting and before
        each query, or choose B among 1, 2 and 4 from held-out training views.
    interpolant : {"auto", "spline", "local"}, default="auto"
        How the manifold passes between training views.
    params, image_shape, normalize, robust
        As for :class:`LinearPose`.

    Attributes
    ----------
    model_, params_, image_shape_, n_features_in_
        As for :class:`LinearPose`.
    """

    _method = "refined"

    def __init__(self, *, components="auto", resolution=0.5, bin="auto", interpolant="auto", params=None, image_shape=None, normalize="auto", robust=False):
        self.components = components
        self.resolution = resolution
        self.bin = bin
        self.interpolant = interpolant
        self.params = params
        self.image_shape = image_shape
        self.normalize = normalize
        self.robust = robust

    def _settings(self):
        s = [("resolution", _number(self.resolution)), ("bin", _integer_or_auto(self.bin, "bin")), ("interpolant", str(self.interpolant))]
        if self.components != "auto":
            s.append(("components", _integer(self.components, "components")))
        return s

    @staticmethod
    def _given(p: dict) -> dict:
        auto = lambda v: "auto" if v is None else v  # noqa: E731
        return {
            "components": auto(p.get("components")),
            "resolution": float(p.get("resolution", 0.5)),
            "bin": auto(p.get("bin")),
            "interpolant": auto(p.get("interpolant")),
        }

    def _check_size(self, n, m):
        _at_least_two(self, n, m)


ESTIMATORS = {c._method: c for c in (LinearPose, EigenspacePose, RefinedPose)}


def _at_least_two(est, n, m):
    if n < 2:
        raise ValueError(f"{type(est).__name__} needs at least 2 training images to span a manifold; got n_samples={n} (1 sample).")


def _number(v) -> str:
    if isinstance(v, str):
        return v
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise TypeError(f"expected a number, got {v!r}")
    return repr(float(v))


def _integer(v, name) -> str:
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)):
        raise TypeError(f"{name} must be a whole number, got {v!r}")
    return str(int(v))


def _integer_or_auto(v, name) -> str:
    return "auto" if v == "auto" else _integer(v, name)


def from_model(model) -> PoseEstimator:
    """A fitted estimator around a model of the Rust core (as a model file gives it), its
    parameters read back from the settings the model records."""
    cls = ESTIMATORS.get(model.method)
    if cls is None:
        raise ValueError(f"a model of method {model.method!r}, which this package has no estimator for")
    params = [tuple(p) for p in model.params]
    est = cls(params=list(params), normalize=_stage(model), robust=model.robust)
    est.set_params(**cls._given(json.loads(model.settings_json).get("params", {})))
    est._set_fitted(model, len(params) == 1, tuple(model.image_shape), params, model.n_features)
    return est


def _stage(model) -> Optional[str]:
    """The ``normalize`` value that fits a model like it: the rule it records (``"auto"`` or the
    choice given), or for a model without one, what its stage normalises (radius: position and
    scale; brightness)."""
    if model.stage_choice_json is not None:
        return json.loads(model.stage_choice_json)["rule"]
    if model.normalize_json is None:
        return "off"
    p = json.loads(model.normalize_json)
    g, b = p.get("radius") is not None, p.get("brightness") is not None
    return "all" if g and b else "geometry" if g else "brightness"


def _reason(message: str) -> str:
    """The reason of a core error about one query ("invalid query = row 0 of the batch: REASON"),
    without the row (the caller knows which image it is)."""
    head, sep, rest = message.partition(" of the batch: ")
    return rest if sep else message
