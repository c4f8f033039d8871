"""Fitting on a Dask cluster: the training statistics summed in shards on the workers, merged
pair-wise in a tree, and the model fitted on one worker (``docs/dask.md``).

The linear model and the eigenspace need from their training set only sums (X^T X over the
images, or the Gram matrix X X^T over the pixels), so shards summed on different workers add up
to the statistics of the whole set, and the model fitted from the merged sum is the
single-process model up to the rounding of the sums' order (``linpose::partial`` in the Rust
library). The images are read from disk by the workers, so every worker must read the paths
given (a shared filesystem, or an object store mounted on each worker), and every worker needs
the same ``linpose`` installed.

Dask does the scheduling, the data movement and the recovery: a worker lost while it reads a
shard (or holds one) has that work redone on another worker (or on it once its nanny restarts
it), up to the scheduler's ``distributed.scheduler.allowed-failures`` times per task (default 3).

Only this module needs ``dask[distributed]``; ``import linpose`` does not.
"""

from __future__ import annotations

import logging
import os
import uuid
import zlib
from typing import Any, List, Optional, Sequence, Tuple

import numpy as np

from . import _linpose
from ._estimators import PoseEstimator, _integer, _number, from_model, resolve_params

__all__ = ["fit"]

log = logging.getLogger("linpose.dask")

# The methods that fit from merged partial statistics, from the library's registry.
_MERGING = tuple(_linpose.merging_methods())


class _Fit:
    """What the tasks of one fit read: the method, its settings and the training set (image
    paths and poses). Each shard task carries it, zlib-compressed when pickled (30 KB for 5000
    images on a pose grid; paths that share their folders and poses on a grid compress well), so
    the shard tasks depend on no other task and Dask spreads them over the workers as it does
    any set of independent tasks (a task that needs another's result is sent where it lies)."""

    def __init__(self, method: str, settings: list, paths: List[str], poses: np.ndarray, params: list):
        self.method = method
        self.settings = settings
        self.paths = paths
        self.poses = poses
        self.params = params

    def __getstate__(self):
        names = zlib.compress("\0".join(self.paths).encode("utf-8", "surrogateescape"), 6)
        poses = zlib.compress(np.ascontiguousarray(self.poses, dtype="<f8").tobytes(), 6)
        return (self.method, self.settings, len(self.paths), names, self.poses.shape, poses, self.params)

    def __setstate__(self, state):
        self.method, self.settings, n, names, shape, poses, self.params = state
        self.paths = zlib.decompress(names).decode("utf-8", "surrogateescape").split("\0") if n else []
        self.poses = np.frombuffer(zlib.decompress(poses), dtype="<f8").reshape(shape).astype(np.float64)


# -- the tasks (module-level functions: workers import them from the installed package) --------


def _plan(job: _Fit) -> Tuple[str, int, int, int, int]:
    """Reads the first image (the size every other must have) and says how the set is cut:
    ``(split, units, width, height, bytes of a partial's sums)``."""
    return _linpose.partial_plan(job.method, job.settings, job.paths, job.poses, job.params)


def _read_shard(job: _Fit, width: int, height: int, index: int, count: int) -> bytes:
    """Shard ``index`` of ``count``: its images read from disk and summed; the partial
    statistics' bytes."""
    return _linpose.partial_read_shard((job.method, job.settings), (job.paths, job.poses, job.params), (width, height), (index, count))


def _merge(a: bytes, b: bytes, a_name: str, b_name: str) -> bytes:
    """The sum of two partial statistics."""
    return _linpose.partial_merge(a, b, a_name, b_name)


def _finish(stats: bytes) -> bytes:
    """The model fitted from the merged statistics, as its model file's bytes."""
    return _linpose.partial_finish(stats, "the merged statistics").to_bytes()


# -- the client side -----------------------------------------------------------------------------


def _settings(settings: dict) -> list:
    """Keyword settings as the library's ``(name, text)`` pairs: ``ridge=1e-3`` is
    ``--ridge 0.001``, ``manifold_step=0.5`` is ``--manifold-step 0.5``."""
    out = []
    for name, value in settings.items():
        flag = name.replace("_", "-")
        if value is None:
            continue
        if isinstance(value, (bool, np.bool_)):
            text = "true" if value else "false"
        elif isinstance(value, str):
            text = value
        elif isinstance(value, (int, np.integer)):
            text = _integer(value, name)
        elif isinstance(value, (float, np.floating)):
            text = _number(value)
        else:
            raise TypeError(f"{name}={value!r}: expected a number, a string or a bool")
        out.append((flag, text))
    return out


def _client(client: Any) -> Any:
    try:
        import distributed
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError(
            "linpose.dask needs Dask's distributed scheduler: pip install 'dask[distributed]' (on the client and every worker)"
        ) from e
    if client is not None:
        return client
    try:
        return distributed.get_client()
    except ValueError:
        raise ValueError(
            "linpose.dask.fit needs a Dask client: make one first (`from distributed import Client; "
            "client = Client('tcp://SCHEDULER:8786')` for a cluster, or `Client()` for a local one) "
            "or pass client="
        ) from None


def _default_shards(client: Any, units: int) -> int:
    threads = sum(client.nthreads().values())
    return max(1, min(units, threads))


def _label(lo: int, hi: int, count: int) -> str:
    """Names the shards lo..hi (0-based, inclusive) in errors."""
    return f"shard {lo + 1}/{count}" if lo == hi else f"shards {lo + 1}-{hi + 1}/{count}"


def fit(
    paths: Sequence[Any],
    poses: Any,
    *,
    client: Any = None,
    method: str = "linear",
    params: Optional[Sequence] = None,
    shards: Optional[int] = None,
    retries: int = 0,
    **settings: Any,
) -> PoseEstimator:
    """Fits ``method`` on the images at ``paths`` (posed at ``poses``) on a Dask cluster.

    The training set is cut into ``shards``; each is read and summed by a task on a worker, the
    partial statistics are merged pair-wise in a tree (log2(shards) levels, so no task receives
    more than two of them) and the model is fitted by one task; only the model's bytes come back
    to the client. The model is the one ``linpose.LinearPose(...).fit`` (or
    ``EigenspacePose``) gives on the same images, up to the rounding of the sums' order.

    How the set is cut depends on its size (``docs/dask.md``): the linear model with more images
    than pixels (N > M) is cut into runs of images, each read once, and takes a fixed ``ridge``
    (0 for the least-squares fit) without ``center``; with N <= M, and for the eigenspace, it is
    cut into runs of pixels: every shard reads every image and keeps its own pixels, and the
    finishing task holds the whole training set (N x M x 4 bytes).

    Parameters
    ----------
    paths : sequence of str or os.PathLike
        The training images (PNG, PNM, JPEG or TIFF; colour read as gray), as every worker reads
        them: absolute paths on a shared filesystem (relative ones are relative to each
        worker's working folder). They must all have the size of the first.
    poses : array of shape (n, K) or (n,)
        Their poses in degrees.
    client : distributed.Client, default=None
        The cluster's client; by default the current one (``distributed.get_client()``).
    method : {merging}, default="linear"
        A method that fits from merged partial statistics.
    params : list of names or (name, period) pairs, default=None
        The pose parameters, as for the estimators (``"azimuth"`` circular, other names linear;
        default ``azimuth`` for one column, ``elevation, azimuth`` for two).
    shards : int, default=None
        How many shards: by default the cluster's worker threads (``sum(client.nthreads())``,
        one shard for each, so every thread sums one and the tree is as shallow as it can be),
        capped by the number of images (or pixels) to share. More shards mean less work redone
        when a worker is lost, but more partial statistics to move and merge; with shards of
        pixels every shard reads every image, so more shards also mean more reads.
    retries : int, default=0
        Passed to Dask for the tasks that read images: how many times to rerun one that raised
        (e.g. a network filesystem's passing error). A worker lost mid-task needs no retries: the
        scheduler reruns the task elsewhere (``distributed.scheduler.allowed-failures``).
    **settings
        The method's settings, as the estimators' parameters or the command line's flags:
        ``ridge=1e-3``, ``center=True`` (linear); ``components=20``, ``energy=0.9``,
        ``manifold_step=0.5`` (eigenspace).

    Returns
    -------
    LinearPose or EigenspacePose
        The fitted estimator of the method (as ``linpose.load`` gives one), its ``model_`` the
        model fitted on the cluster.

    Examples
    --------
    >>> from distributed import Client                      # doctest: +SKIP
    >>> client = Client("tcp://scheduler:8786")             # doctest: +SKIP
    >>> est = linpose.dask.fit(paths, poses, method="linear", ridge=1e-3)   # doctest: +SKIP
    >>> est.predict(images)                                 # doctest: +SKIP
    """
    client = _client(client)
    if "normalize" in settings:
        raise ValueError("normalize: the normalisation stage is fitted in one process only (linpose.LinearPose(normalize=...).fit)")
    if method not in _MERGING:
        raise ValueError(f"method={method!r}: a distributed fit sums partial statistics, which these methods merge: {_MERGING}")
    paths = [os.fspath(p) for p in paths]
    for p in paths:
        if not isinstance(p, str):
            raise TypeError(f"paths: {p!r} is not a path (str or os.PathLike of str)")
    y = np.ascontiguousarray(poses, dtype=np.float64)
    if y.ndim == 1:
        y = y.reshape(-1, 1)
    if y.ndim != 2 or len(y) != len(paths):
        raise ValueError(f"poses have shape {np.shape(poses)}; {len(paths)} images need (n, K) or (n,) with n = {len(paths)}")
    if not paths:
        raise ValueError("paths: no training images")
    if shards is not None and (isinstance(shards, bool) or not isinstance(shards, (int, np.integer)) or shards < 1):
        raise ValueError(f"shards={shards!r}: expected a whole number >= 1")
    job = _Fit(method, _settings(settings), paths, y, resolve_params(params, y.shape[1]))

    # A tag for the keys, so that the dashboard shows whose tasks these are.
    tag = uuid.uuid4().hex[:8]
    # Every task is impure: the images are read anew by each fit (they may have changed).
    plan = client.submit(_plan, job, key=f"linpose-plan-{tag}", pure=False, retries=retries)
    split, units, width, height, stats_bytes = plan.result()
    del plan
    count = _default_shards(client, units) if shards is None else int(shards)
    if count > units:
        raise ValueError(f"shards={count}: more shards than the {units} {split} to share")
    log.info(
        "%s on %d images of %dx%d: %d shards of %s (of %d), %d bytes of sums each",
        method,
        len(y),
        width,
        height,
        count,
        split,
        units,
        stats_bytes,
    )

    level = [
        client.submit(_read_shard, job, width, height, i, count, key=f"linpose-shard-{i + 1}-of-{count}-{tag}", pure=False, retries=retries)
        for i in range(count)
    ]
    # The futures of what is merged are let go as the tree is built: the scheduler keeps each
    # result only until the task that needs it has run (and recomputes it if it is lost first).
    spans = [(i, i) for i in range(count)]
    while len(level) > 1:
        nxt, nspans = [], []
        for j in range(0, len(level) - 1, 2):
            (a0, a1), (b0, b1) = spans[j], spans[j + 1]
            nxt.append(
                client.submit(
                    _merge,
                    level[j],
                    level[j + 1],
                    _label(a0, a1, count),
                    _label(b0, b1, count),
                    key=f"linpose-merge-{a0 + 1}-{b1 + 1}-of-{count}-{tag}",
                    pure=False,
                )
            )
            nspans.append((a0, b1))
        if len(level) % 2:
            nxt.append(level[-1])
            nspans.append(spans[-1])
        level, spans = nxt, nspans
    model = client.submit(_finish, level[0], key=f"linpose-finish-{tag}", pure=False)
    del level
    data = model.result()
    return from_model(_linpose.Model.from_bytes(data))


# The methods in fit's documentation, as the registry lists them.
if fit.__doc__:
    fit.__doc__ = fit.__doc__.replace("{merging}", "{" + ", ".join(f'"{m}"' for m in _MERGING) + "}")
