"""linpose: the pose of an object from its appearance.

Give it images of an object under known poses (a turntable, a robot arm, a render farm) and it
learns to tell the pose of a new image. Three methods, each a scikit-learn estimator:

- :class:`LinearPose`: Okatani & Deguchi's linear model (MVA 2000), each pose parameter a linear
  function of the pixels, circular parameters as (cos, sin);
- :class:`EigenspacePose`: Murase & Nayar's parametric eigenspace, the paper's baseline;
- :class:`RefinedPose`: linpose's refined eigenspace, its most accurate;

and for several objects, :class:`ObjectRecognizer`, a classifier: which object an image shows
(or none of the known ones), then its pose.

The models are the Rust library's, and their files are the command line's: :func:`load` reads
one ``linpose train`` wrote, and ``save`` writes one ``linpose predict`` reads. :func:`synth`
renders turntable data sets (optionally in cluttered, occluded scenes), :func:`scene` puts
studio views into such scenes, :func:`read_dataset` reads a data set folder, :func:`train_mask`
picks the paper's training views and :func:`pose_error` is the error measure of ``linpose eval``.

:mod:`linpose.dask` fits the linear model and the eigenspace on a Dask cluster (``import
linpose.dask``; it needs ``dask[distributed]``, which ``import linpose`` does not).
"""

from __future__ import annotations

import os
from typing import Optional, Sequence, Tuple, Union

import numpy as np

from . import _linpose
from ._estimators import EigenspacePose, LinearPose, PoseEstimator, RefinedPose, from_model, resolve_params
from ._objects import ObjectRecognizer, from_objects

__version__ = _linpose.__version__

__all__ = [
    "LinearPose",
    "EigenspacePose",
    "RefinedPose",
    "PoseEstimator",
    "ObjectRecognizer",
    "load",
    "from_bytes",
    "synth",
    "scene",
    "read_dataset",
    "train_mask",
    "pose_error",
]

PathLike = Union[str, "os.PathLike[str]"]


def load(path: PathLike) -> Union[PoseEstimator, ObjectRecognizer]:
    """Reads a model file (written by ``linpose train`` or an estimator's ``save``) as a fitted
    estimator of its method, or, for a model of several objects, a fitted
    :class:`ObjectRecognizer`."""
    path = os.fspath(path)
    if _linpose.holds_objects(path):
        return from_objects(_linpose.load_objects(path))
    return from_model(_linpose.load(path))


def from_bytes(data: bytes) -> Union[PoseEstimator, ObjectRecognizer]:
    """A fitted estimator from a model file's bytes (an estimator's ``to_bytes``)."""
    data = bytes(data)
    if _linpose.bytes_hold_objects(data):
        return from_objects(_linpose.Objects.from_bytes(data))
    return from_model(_linpose.Model.from_bytes(data))


def synth(
    object: Optional[str] = None,
    *,
    random: Optional[int] = None,
    mesh: Optional[PathLike] = None,
    azimuth: str = "0:327:3",
    elevation: str = "32:77:3",
    roll: Optional[str] = None,
    light: Optional[str] = None,
    size: Tuple[int, int] = (160, 120),
    perspective: bool = False,
    specular: float = 0.0,
    jitter: Optional[Tuple[float, float, float]] = None,
    jitter_seed: int = 0,
    background: Union[float, str, "os.PathLike[str]"] = 0.0,
    occlude: float = 0.0,
    scene_seed: int = 0,
    return_scene: bool = False,
):
    """Renders a turntable data set in memory, the images ``linpose synth`` would write.

    Give one of ``object`` (a built-in: ``duck``, ``pot``, ``cap``, ``twin``, ``column``, ...),
    ``random`` (the seed of a generated object) or ``mesh`` (a Wavefront OBJ file). Poses are
    every ``elevation`` for every ``azimuth`` (``"START:STOP:STEP"`` degrees) and, when given,
    every ``roll`` (the camera turned about its optical axis, the image counter-clockwise) and
    every ``light`` (the light's azimuth around the turntable's axis, the camera at 0; 35 when
    not given), as ``linpose synth --roll/--light``; ``size`` is (width, height);
    ``jitter=(shift, scale, exposure)`` moves, scales and brightens each view at random (up to
    ``shift`` pixels, ``1 +- scale``, ``1 +- exposure``) from ``jitter_seed``. The images are
    held in memory: n x width x height bytes.

    Scenes, as ``linpose synth --background/--occlude/--seed``: ``background`` is a level from 0
    (black) to 1 (white), ``"texture"`` (procedural clutter), ``"noise"`` (pixel noise) or a
    folder of photographs (a random crop of a random one), each view its own draw from
    ``scene_seed``; ``occlude`` in [0, 1) hides about that share of each view's object behind one
    or two striped occluders (docs/scenes.md).

    Returns ``(images, poses, params)``: ``uint8`` images (n, height, width), poses (n, K) in
    degrees (elevation, azimuth, then roll and light when given) and the parameters, e.g.
    ``[("elevation", None), ("azimuth", 360.0)]``; roll and light are circular (period 360)
    when their grid goes round a whole turn, linear (``None``) otherwise. With
    ``return_scene=True`` a fourth item says what each view's scene is (see :func:`scene`).
    """
    images, poses, params, info = _linpose.synth(
        (object, random, None if mesh is None else os.fspath(mesh)),
        (azimuth, elevation, roll, light),
        (tuple(size), perspective, float(specular)),
        (None if jitter is None else tuple(float(v) for v in jitter), jitter_seed),
        (_background(background), float(occlude), int(scene_seed), bool(return_scene)),
    )
    if return_scene:
        return images, poses, params, _scene_info(info, len(images))
    return images, poses, params


def scene(
    images,
    background: Union[float, str, "os.PathLike[str]"] = "texture",
    occlude: float = 0.0,
    seed: int = 0,
):
    """Puts studio views into scenes, as ``linpose scene`` does to a data set's views.

    ``images`` are ``uint8`` (n, h, w) gray or (n, h, w, 3) RGB views of an object against a
    uniform studio backdrop. In each the object is found (the pixels that differ from the
    backdrop's level, measured on the border, by more than its own spread; specks left out,
    small enclosed holes filled), the backdrop replaced by ``background`` (as :func:`synth`'s,
    ``"texture"`` by default) and about ``occlude`` (in [0, 1)) of the object hidden behind
    occluders; view i draws scene i of ``seed``. A view without an object to find is a
    ``ValueError`` naming its index.

    Returns ``(images, info)``: the views in their scenes (``uint8``, the input's shape) and a
    dict: ``mask`` (n, h, w) bool, the object's pixels; ``occluded`` (n, h, w) bool, the pixels
    the occluders cover; ``hidden`` (n,), the share of each object they hide; ``records``, one
    dict per view as ``scene.csv`` has it (``image``, ``background``, ``seed``, ``occlude``,
    ``hidden``, ``object_pixels``, ``occluders``: ``(shape, cx, cy, hx, hy)`` in pixels).
    """
    images = np.ascontiguousarray(images)
    if images.dtype != np.uint8:
        raise TypeError(f"images must be uint8, not {images.dtype}")
    out, info = _linpose.scene(images, (_background(background), float(occlude), int(seed)))
    return out, _scene_info(info, len(images))


def _background(background) -> str:
    """A background as the command line takes it: a level's number, a kind, or a folder."""
    if isinstance(background, (int, float)) and not isinstance(background, bool):
        return repr(float(background))
    return os.fspath(background)


_RECORD_FIELDS = ("image", "background", "seed", "occlude", "hidden", "object_pixels", "occluders")


def _scene_info(info, n: int) -> dict:
    mask, occluded, records = info
    records = [dict(zip(_RECORD_FIELDS, r)) for r in records]
    hidden = np.array([r["hidden"] for r in records] if records else np.zeros(n), dtype=np.float64)
    return {"mask": mask, "occluded": occluded, "hidden": hidden, "records": records}


def read_dataset(path: PathLike, object: Optional[int] = None):
    """Reads a data set folder as the command line does: ``poses.csv`` beside its images (PNG,
    PNM, JPEG or TIFF), or a COIL folder (``objO__K.png``) with ``object=O``.

    Returns ``(images, poses, params, names)``: images (n, h, w), ``uint8`` when every image is
    8-bit (colour turned gray as PIL's ``convert("L")``), else ``float32`` in [0, 1]; poses
    (n, K) in degrees; the parameters as ``(name, period)`` pairs; each image's path as in
    ``poses.csv``. Rows are in the data set's order, so fitting on them gives the model file
    ``linpose train`` writes.
    """
    return _linpose.read_dataset(os.fspath(path), object)


def train_mask(poses, params: Sequence, step: float) -> np.ndarray:
    """Which rows the paper's protocol trains on: every parameter a multiple of ``step`` degrees
    from its smallest value (``linpose train --train-step``). A boolean array (n,)."""
    poses = np.ascontiguousarray(poses, dtype=np.float64)
    if poses.ndim == 1:
        poses = poses.reshape(-1, 1)
    return _linpose.train_mask(poses, resolve_params(params, poses.shape[1]), float(step))


def pose_error(y_true, y_pred, params: Optional[Sequence] = None) -> np.ndarray:
    """The pose error of each row in degrees: the angle on the viewing sphere between the true
    and the estimated pose (elevation and azimuth), or the circular or plain difference for a
    single parameter; what ``linpose eval`` reports. An array (n,)."""
    a = np.ascontiguousarray(y_true, dtype=np.float64)
    b = np.ascontiguousarray(y_pred, dtype=np.float64)
    a = a.reshape(len(a), -1)
    b = b.reshape(len(b), -1)
    return _linpose.pose_error(a, b, resolve_params(params, a.shape[1]))
