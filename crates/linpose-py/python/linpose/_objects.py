"""The recogniser: which of several objects each image shows ("none of these" included), then its
pose, as a scikit-learn classifier.

It wraps a fitted many-object model of the Rust library (``model_``), the model ``linpose train``
fits on a data set of many objects: Murase & Nayar's universal eigenspace (or the paper's linear
model with one-hot targets) tells the objects apart, each object's own eigenspace checks the
answer, and each object's own pose model gives the pose.
"""

from __future__ import annotations

import json
from typing import Any, Optional

import numpy as np
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.utils.multiclass import check_classification_targets
from sklearn.utils.validation import validate_data

from . import _linpose
from ._core import _DTYPES, CoreModel, _flatten
from ._estimators import ESTIMATORS, LinearPose, PoseEstimator, _integer, _number, _stage, resolve_params


class ObjectRecognizer(CoreModel, ClassifierMixin, BaseEstimator):
    """Which object each image shows, or none of the known ones, then its pose.

    ``fit(X, y, poses=None)``: ``y`` names each training image's object (any labels, as for a
    scikit-learn classifier). With ``poses`` (degrees, as the pose estimators take them), each
    object also gets a pose model (``pose``) and each object's appearance manifold is the curve
    through its views at their poses, as Murase & Nayar build it. Without them, each object's
    manifold is its training views' points, and there is no pose: recognition of objects whose
    poses nobody recorded (views between the training views then lie nearer a curve than any
    point, so give the poses when you have them).

    ``predict`` gives each image's object, or ``unknown_label`` when it is none of the known
    objects: its distance to the nearest object exceeds what that object's held-out training
    views show, in the shared space and then in the object's own eigenspace, or another object's
    own manifold lies nearer (``unknown="calibrated"``). ``predict_pose`` gives the pose of each
    image recognised.

    Parameters
    ----------
    recognizer : {recognizers}, default="universal"
        How an image's object is told: {recognizer_summaries}.
    components : int, default=20
        Dimensions of the universal eigenspace (and at most of each object's own), capped at the
        number of training images less one.
    manifold_step : float, default=0.5
        The manifolds' resampling step in degrees (fitted with poses).
    unknown : "calibrated", None or float, default="calibrated"
        When an image is none of the known objects: calibrated on each object's held-out
        training views, ``None`` never, or beyond this distance in the recogniser's measure.
    unknown_label : default=None
        What ``predict`` gives for an image of none of the known objects; ``None``: -1 for
        numeric labels (one less than the least when -1 is a label), ``"unknown"`` for text
        (with ``_`` appended while it names an object). A label given must be of the labels'
        kind (a number or text) and none of them, so that predictions and labels compare (as
        scikit-learn's scores need).
    pose : LinearPose, EigenspacePose or RefinedPose, default=None
        The pose method for each object and its parameters (an unfitted estimator; ``None``:
        ``LinearPose()``, the command line's default). Only used when ``fit`` gets poses; its
        own ``params``, ``image_shape`` and ``normalize`` must be left at their defaults (set them
        here).
    params : list, default=None
        The pose parameters, as for :class:`LinearPose`.
    image_shape : (h, w), default=None
        As for :class:`LinearPose`.
    normalize : {"auto", "off", None, "all", "geometry", "brightness"}, default="auto"
        One normalisation stage fitted on every object's training views together, every query
        going through it first (images as a camera takes them). ``"auto"`` chooses it on the
        objects' held-out training views by their pose error, as ``linpose train`` does (without
        poses there is none to choose on, and the images are used as they are); ``"off"`` or
        ``None``: none; the others force it.

    Attributes
    ----------
    model_ : the Rust many-object model
    classes_ : array of the objects' labels
    params_ : the pose parameters, ``None`` when fitted without poses
    unknown_label_ : the label ``predict`` gives for none of the known objects
    image_shape_, n_features_in_
        As for :class:`LinearPose`.
    """

    _core = _linpose.Objects

    def __init__(
        self,
        *,
        recognizer="universal",
        components=20,
        manifold_step=0.5,
        unknown="calibrated",
        unknown_label=None,
        pose=None,
        params=None,
        image_shape=None,
        normalize="auto",
    ):
        self.recognizer = recognizer
        self.components = components
        self.manifold_step = manifold_step
        self.unknown = unknown
        self.unknown_label = unknown_label
        self.pose = pose
        self.params = params
        self.image_shape = image_shape
        self.normalize = normalize

    # -- fitting -------------------------------------------------------------------------------

    def fit(self, X, y, poses=None):
        """Fits the recogniser on images ``X`` of the objects ``y`` and, with ``poses``, each
        object's pose model.

        Parameters
        ----------
        X : array of shape (n, h, w) or (n, pixels)
            Training images. ``uint8``/``uint16`` are image levels, floats are features.
        y : array of shape (n,)
            Each image's object (any labels).
        poses : array of shape (n, K) or (n,), default=None
            Their poses in degrees (see ``params``); each object's must form a full grid (one
            view at each combination of its parameters' values), as the manifolds pass through
            them. Without them the recogniser takes the views as points and gives no pose.

        Returns
        -------
        self
        """
        X, shape = _flatten(X, self.image_shape)
        X, y = validate_data(self, X, y, dtype=_DTYPES, order="C")
        check_classification_targets(y)
        n, m = X.shape
        if n < 2:
            raise ValueError(f"ObjectRecognizer needs at least 2 training images; got n_samples={n} (1 sample).")
        if m < 2:
            raise ValueError("ObjectRecognizer needs images of at least 2 pixels (n_features=1): scaled to unit energy, images of one pixel are all alike")
        if shape is None:
            shape = (1, m)
        if shape[0] * shape[1] != m:
            raise ValueError(f"image_shape {shape} has {shape[0] * shape[1]} pixels but X has {m} values per image")
        classes, labels = np.unique(y, return_inverse=True)
        names = [str(c) for c in classes]
        if len(set(names)) != len(names):
            raise ValueError(f"the labels {classes.tolist()} do not read as distinct names")
        unknown_label = _unknown_label(classes, self.unknown_label)
        if self.unknown is None:
            unknown: Any = "off"
        elif isinstance(self.unknown, str):
            unknown = self.unknown
        else:
            unknown = float(_number(self.unknown))
        common = dict(
            recognizer=(str(self.recognizer), int(_integer(self.components, "components")), float(_number(self.manifold_step)), unknown),
            images=(X, shape[0], shape[1]),
            labels=(
                np.ascontiguousarray(labels, dtype=np.int64),
                names,
                _stored_labels(classes, unknown_label, self.unknown_label is not None),
            ),
            normalize=self.normalize,
        )
        y_1d = False
        params = None
        self._release()
        if poses is None:
            model = _linpose.fit_objects(**common)
        else:
            p = np.asarray(poses, dtype=np.float64)
            if p.ndim not in (1, 2) or len(p) != n:
                raise ValueError(f"poses has shape {p.shape}; {n} images need (n, K) or (n,) poses")
            y_1d = p.ndim == 1
            p2 = p.reshape(-1, 1) if y_1d else p
            params = resolve_params(self.params, p2.shape[1])
            method = LinearPose() if self.pose is None else self.pose
            if not isinstance(method, PoseEstimator):
                raise TypeError(f"pose must be a LinearPose, EigenspacePose or RefinedPose, got {method!r}")
            for name, default in (("params", None), ("image_shape", None), ("normalize", "auto")):
                if getattr(method, name) != default:
                    raise ValueError(f"pose={method!r}: set {name} on the ObjectRecognizer, not on its pose estimator")
            model = _linpose.fit_objects(**common, poses=(np.ascontiguousarray(p2), params, method._method, method._settings()))
        self._set_fitted(model, classes, unknown_label, params, y_1d, shape, m)
        return self

    def _set_fitted(
        self, model: Any, classes: np.ndarray, unknown_label: Any, params: Optional[list], y_1d: bool, image_shape, n_features: int
    ) -> None:
        self.model_ = model
        self.classes_ = classes
        self.unknown_label_ = unknown_label
        self.params_ = params
        self.image_shape_ = tuple(image_shape)
        self.n_features_in_ = n_features
        self._y_1d = y_1d

    # -- recognising ---------------------------------------------------------------------------

    def _labels(self, index: np.ndarray) -> np.ndarray:
        """The labels of object indices, ``unknown_label_`` for -1: always of one dtype, the
        labels' and the unknown label's together (whether or not any image is unknown)."""
        label = self.unknown_label_
        kind = np.min_scalar_type(label) if isinstance(label, (int, float, np.number)) else np.asarray(label).dtype
        out = self.classes_[np.maximum(index, 0)].astype(np.result_type(self.classes_.dtype, kind), copy=False)
        out[index < 0] = label
        return out

    def recognize(self, X):
        """Each image's object in detail: ``(label, nearest, distance, confidence)``: the
        object's label (``unknown_label_`` for none of the known objects), the nearest object's
        label even then, the distance to it in the recogniser's measure, and how far it stands
        out from the second nearest, 1 - (distance / second distance)^2 in [0, 1] (a margin,
        not a probability)."""
        obj, nearest, distance, confidence = self._model().recognize(self._rows(X))
        return self._labels(obj), self.classes_[nearest], distance, confidence

    def predict(self, X):
        """Each image's object: one of ``classes_``, or ``unknown_label_`` for none of them."""
        return self._labels(self._model().recognize(self._rows(X))[0])

    def predict_pose(self, X):
        """Each image's pose in degrees from its object's pose model: (n, K), or (n,) when
        fitted on 1-D poses; NaN for an image of none of the known objects. Needs a model
        fitted with poses."""
        pose = self._model().estimate(self._rows(X))[4]
        if pose is None:
            raise ValueError("this ObjectRecognizer was fitted without poses: it tells objects apart but gives no pose (fit it with poses=...)")
        return pose[:, 0] if self._y_1d else pose

    def distances(self, X):
        """Each image's distance to each object, (n, len(classes_)), in the recogniser's
        measure (smaller: more like that object)."""
        return self._model().distances(self._rows(X))

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.allow_nan = False
        return tags


# The recognisers in the documentation, as the registry lists them.
if ObjectRecognizer.__doc__:
    ObjectRecognizer.__doc__ = ObjectRecognizer.__doc__.replace(
        "{recognizers}", "{" + ", ".join(f'"{n}"' for n, _ in _linpose.recognizers()) + "}"
    ).replace("{recognizer_summaries}", "; ".join(f'"{n}", {s}' for n, s in _linpose.recognizers()))


def _unknown_label(classes: np.ndarray, given: Any) -> Any:
    """The label for none of the known objects: ``given``, checked to be of the labels' kind and
    none of them, or by default -1 (numbers) or "unknown" (text), moved off the labels."""
    numeric = classes.dtype.kind in "iufb"
    if given is None:
        if numeric:
            return -1 if -1 not in classes else int(np.floor(classes.min())) - 1
        label = "unknown"
        while label in set(map(str, classes)):
            label += "_"
        return label
    if numeric != isinstance(given, (int, float, np.integer, np.floating)) or isinstance(given, (bool, np.bool_)):
        raise ValueError(f"unknown_label={given!r} is not of the labels' kind ({classes.dtype}): predictions and labels would not compare")
    if given in set(classes.tolist()):
        raise ValueError(f"unknown_label={given!r} is one of the objects' labels")
    return given


def _stored_labels(classes: np.ndarray, unknown_label: Any, given: bool) -> Optional[str]:
    """The labels for the model file where its names would not give them back: numbers (and
    any labels but text) as JSON values with their dtype, or text labels with an
    ``unknown_label`` given. ``None`` for text labels with the default unknown label, whose
    names are the labels (so such a file is the one the command line writes). Labels JSON cannot
    hold (bytes, objects) come back as their names."""
    if classes.dtype.kind == "U" and not given:
        return None
    unknown = unknown_label.item() if isinstance(unknown_label, np.generic) else unknown_label
    try:
        return json.dumps({"values": classes.tolist(), "unknown": unknown, "kind": classes.dtype.str if classes.dtype.kind != "O" else "object"})
    except (TypeError, ValueError):
        return None


def from_objects(model) -> ObjectRecognizer:
    """A fitted recogniser around a many-object model of the Rust core (as a model file gives
    it): its labels are those it was fitted with where the file keeps them (numbers stay numbers),
    else the objects' names; its parameters read back from the settings."""
    s = json.loads(model.settings_json)["params"]
    unknown = s["unknown"]
    unknown = "calibrated" if unknown == "calibrated" else None if unknown == "off" else float(unknown["threshold"])
    pose = None
    if model.method is not None:
        cls = ESTIMATORS.get(model.method)
        if cls is None:
            raise ValueError(f"pose models of method {model.method!r}, which this package has no estimator for")
        pose = cls(**cls._given(json.loads(model.pose_settings_json(0)).get("params", {})))
    params = None if model.params is None else [tuple(p) for p in model.params]
    est = ObjectRecognizer(
        recognizer=s["kind"],
        components=int(s["components"]),
        manifold_step=float(s["manifold_step"]),
        unknown=unknown,
        pose=pose,
        params=params,
        normalize=_stage(model),
    )
    if model.labels_json is None:
        classes = np.array(model.names)
        unknown_label = _unknown_label(classes, None)
    else:
        labels = json.loads(model.labels_json)
        classes = np.array(labels["values"], dtype=np.dtype(labels["kind"]))
        unknown_label = labels["unknown"]
        if unknown_label != _unknown_label(classes, None):
            est.unknown_label = unknown_label
    est._set_fitted(model, classes, unknown_label, params, params is not None and len(params) == 1, model.image_shape, model.n_features)
    return est
