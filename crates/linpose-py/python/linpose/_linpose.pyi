"""Type stubs of linpose's Rust core (the compiled module ``linpose._linpose``)."""

from os import PathLike
from typing import List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str
FORMAT_VERSION: int

Params = List[Tuple[str, Optional[float]]]
Images = npt.NDArray[Union[np.uint8, np.uint16, np.float32, np.float64]]

class Model:
    """A fitted pose model of any method (the model file's contents)."""

    method: str
    image_shape: Tuple[int, int]
    n_features: int
    params: Params
    train_poses: npt.NDArray[np.float64]
    settings_json: str
    normalize_json: Optional[str]
    robust: bool
    coefficients: Optional[npt.NDArray[np.float64]]
    model_bytes: int
    storage: Tuple[List[Tuple[str, int]], int]
    def predict(self, x: Images) -> npt.NDArray[np.float64]: ...
    def estimate(
        self, x: Images, top: int
    ) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
    def to_bytes(self) -> bytes: ...
    @staticmethod
    def from_bytes(data: bytes) -> "Model": ...
    def save(self, path: Union[str, PathLike[str]]) -> int: ...
    def tensors(self) -> List[Tuple[str, List[int], npt.NDArray[np.float64]]]: ...

class Serve:
    """A fitted estimator's predict in one call: the poses of an array the core reads as it is,
    or None for anything else."""

    def __init__(self, model: Model, n_features: int, y_1d: bool, name: str) -> None: ...
    def __call__(self, x: object) -> Optional[npt.NDArray[np.float64]]: ...

def fit(
    method: str,
    settings: Sequence[Tuple[str, str]],
    images: Tuple[Images, int, int],
    y: npt.NDArray[np.float64],
    params: Params,
    stages: Tuple[Optional[str], bool] = (None, False),
) -> Model: ...
def load(path: Union[str, PathLike[str]]) -> Model: ...

class Objects:
    """A fitted many-object model: a recogniser and, fitted with poses, each object's pose model."""

    names: List[str]
    recognizer: str
    method: Optional[str]
    image_shape: Tuple[int, int]
    n_features: int
    params: Optional[Params]
    settings_json: str
    normalize_json: Optional[str]
    labels_json: Optional[str]
    model_bytes: int
    def estimate(
        self, x: Images
    ) -> Tuple[
        npt.NDArray[np.int64],
        npt.NDArray[np.int64],
        npt.NDArray[np.float64],
        npt.NDArray[np.float64],
        Optional[npt.NDArray[np.float64]],
    ]: ...
    def recognize(
        self, x: Images
    ) -> Tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
    def distances(self, x: Images) -> npt.NDArray[np.float64]: ...
    def pose_settings_json(self, k: int) -> Optional[str]: ...
    def to_bytes(self) -> bytes: ...
    @staticmethod
    def from_bytes(data: bytes) -> "Objects": ...
    def save(self, path: Union[str, PathLike[str]]) -> int: ...

def fit_objects(
    recognizer: Tuple[str, int, float, Union[str, float]],
    images: Tuple[Images, int, int],
    labels: Tuple[npt.NDArray[np.int64], Sequence[str], Optional[str]],
    poses: Optional[Tuple[npt.NDArray[np.float64], Params, str, Sequence[Tuple[str, str]]]] = None,
    normalize: Optional[str] = None,
) -> Objects: ...
def load_objects(path: Union[str, PathLike[str]]) -> Objects: ...
def holds_objects(path: Union[str, PathLike[str]]) -> bool: ...
def bytes_hold_objects(data: bytes) -> bool: ...
def methods() -> List[Tuple[str, str, List[Tuple[str, str, str]]]]: ...
def merging_methods() -> List[str]: ...
def recognizers() -> List[Tuple[str, str]]: ...
# A scene's record: (image, background, seed, occlude, hidden, object_pixels, occluders), each
# occluder (shape, cx, cy, hx, hy); and views' scenes: (mask, occluded, records).
SceneRecord = Tuple[str, str, int, float, float, int, List[Tuple[str, float, float, float, float]]]
SceneInfo = Tuple[npt.NDArray[np.bool_], npt.NDArray[np.bool_], List[SceneRecord]]

def synth(
    source: Tuple[Optional[str], Optional[int], Optional[str]],
    poses: Tuple[str, str, Optional[str], Optional[str]],
    look: Tuple[Tuple[int, int], bool, float],
    jitter: Tuple[Optional[Tuple[float, float, float]], int],
    scene: Tuple[str, float, int, bool],
) -> Tuple[npt.NDArray[np.uint8], npt.NDArray[np.float64], Params, Optional[SceneInfo]]: ...
def scene(images: npt.NDArray[np.uint8], scene: Tuple[str, float, int]) -> Tuple[npt.NDArray[np.uint8], SceneInfo]: ...
def read_dataset(
    path: Union[str, PathLike[str]], object: Optional[int] = None
) -> Tuple[npt.NDArray[Union[np.uint8, np.float32]], npt.NDArray[np.float64], Params, List[str]]: ...
def train_mask(poses: npt.NDArray[np.float64], params: Params, step: float) -> npt.NDArray[np.bool_]: ...
def pose_error(y_true: npt.NDArray[np.float64], y_pred: npt.NDArray[np.float64], params: Params) -> npt.NDArray[np.float64]: ...

# The tasks of a distributed fit (linpose.dask): partial training statistics as the bytes of a
# partial statistics file (what `linpose train --shard I/N --partial FILE` writes).
def partial_plan(
    method: str,
    settings: Sequence[Tuple[str, str]],
    paths: Sequence[str],
    poses: npt.NDArray[np.float64],
    params: Params,
) -> Tuple[str, int, int, int, int]:
    """(split "images" or "pixels", units to share, width, height, bytes of a partial's sums)."""
    ...
def partial_read_shard(
    fit: Tuple[str, Sequence[Tuple[str, str]]],
    data: Tuple[Sequence[str], npt.NDArray[np.float64], Params],
    size: Tuple[int, int],
    shard: Tuple[int, int],
) -> bytes: ...
def partial_merge(a: bytes, b: bytes, a_name: str = ..., b_name: str = ...) -> bytes: ...
def partial_finish(data: bytes, name: str = ...) -> Model: ...
def partial_describe(data: bytes) -> str: ...
