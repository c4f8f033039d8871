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
renders turntable data sets, :func:`read_dataset` reads a data set folder, :func:`train_mask`
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

    Returns ``(images, poses, params)``: ``uint8`` images (n, height, width), poses (n, K) in
    degrees (elevation, azimuth, then roll and light when given) and the parameters, e.g.
    ``[("elevation", None), ("azimuth", 360.0)]``; roll and light are circular (period 360)
    when their grid goes round a whole turn, linear (``None``) otherwise.
    """
    return _linpose.synth(
        (object, random, None if mesh is None else os.fspath(mesh)),
        (azimuth, elevation, roll, light),
        (tuple(size), perspective, float(specular)),
        (None if jitter is None else tuple(float(v) for v in jitter), jitter_seed),
    )


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
