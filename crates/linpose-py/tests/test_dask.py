"""linpose.dask.fit on a local Dask cluster of two worker processes: the model summed in shards
on the workers and merged pair-wise is the single-process model (linear with more images than
pixels, shards of images; linear with fewer, and the eigenspace, shards of pixels); a worker
killed while shards run changes nothing; inputs that do not fit give errors naming the cause."""

import os
import re
import shutil
import signal
import time
from pathlib import Path

import numpy as np
import pytest

distributed = pytest.importorskip("distributed")

import linpose  # noqa: E402
import linpose.dask  # noqa: E402
from conftest import run  # noqa: E402


@pytest.fixture(scope="module")
def client():
    """Two worker processes of one thread each, restarted by their nannies when killed."""
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0") as cluster:
        with distributed.Client(cluster) as c:
            yield c


def _render(cli, out, size):
    run(cli, "synth", "--object", "duck", "--azimuth", "0:355:5", "--elevation", "30:60:10", "--size", size, "--out", out)
    X, y, params, names = linpose.read_dataset(out)
    return X, y, params, [str(out / n) for n in names]


@pytest.fixture(scope="module")
def small(cli, tmp_path_factory):
    """288 views of 16 x 12 (192 pixels): more images than pixels."""
    return _render(cli, tmp_path_factory.mktemp("dask") / "small", "16x12")


@pytest.fixture(scope="module")
def large(cli, tmp_path_factory):
    """288 views of 32 x 24 (768 pixels): fewer images than pixels."""
    return _render(cli, tmp_path_factory.mktemp("dask") / "large", "32x24")


def _rel(want, got):
    want, got = np.asarray(want, dtype=np.float64), np.asarray(got, dtype=np.float64)
    return float(np.linalg.norm(want - got) / max(np.linalg.norm(want), 1e-300))


def _compare(single, merged, X, params):
    """How far apart two models are: the largest relative difference of their f32 arrays and of
    their f64 arrays (as their model files hold them), and of their estimates of ``X``
    (degrees on the viewing sphere)."""
    a = {name: np.asarray(v) for name, _, v in single.model_.tensors()}
    b = {name: np.asarray(v) for name, _, v in merged.model_.tensors()}
    assert a.keys() == b.keys()
    f32 = f64 = 0.0
    for name in a:
        assert a[name].shape == b[name].shape, name
        r = _rel(a[name], b[name])
        if np.array_equal(a[name].astype(np.float32).astype(np.float64), a[name]):
            f32 = max(f32, r)
        else:
            f64 = max(f64, r)
    deg = float(np.max(linpose.pose_error(single.predict(X), merged.predict(X), params)))
    return f32, f64, deg


CASES = [
    # More images than pixels: shards of images, X^T X summed in f64.
    ("small", "linear", {"ridge": 1e-3}, 5),
    # Fewer: shards of pixels and their Gram matrix; the paper's exact fit, and the ridge of the
    # least leave-one-out error (a rule only the pixel split can follow).
    ("large", "linear", {}, 4),
    ("large", "linear", {"ridge": "auto"}, 3),
    # The eigenspace, with the default number of shards (one per worker thread).
    ("large", "eigenspace", {"components": 12}, None),
]


@pytest.mark.parametrize("case, method, settings, shards", CASES)
def test_dask_model_is_the_single_process_model(client, small, large, case, method, settings, shards):
    """The model from the cluster against the estimator's on the same images, both as their
    model files hold them (the weights and eigenimages in f32): the f32 arrays equal to their
    rounding, the f64 arrays to 1e-9, the estimates to 1e-4 degrees."""
    X, y, params, paths = {"small": small, "large": large}[case]
    t0 = time.perf_counter()
    merged = linpose.dask.fit(paths, y, client=client, method=method, params=params, shards=shards, **settings)
    dt = time.perf_counter() - t0
    cls = {"linear": linpose.LinearPose, "eigenspace": linpose.EigenspacePose}[method]
    single = linpose.from_bytes(cls(params=params, **settings).fit(X, y).to_bytes())
    assert type(merged) is cls and merged.params_ == params and merged.image_shape_ == X.shape[1:]
    f32, f64, deg = _compare(single, merged, X, params)
    n_shards = shards or sum(client.nthreads().values())
    print(
        f"\n{method} {settings} on {len(X)} images of {X.shape[2]}x{X.shape[1]}, {n_shards} shards: {dt:.2f} s;"
        f" f32 arrays differ by {f32:.1e}, f64 arrays by {f64:.1e} (relative), estimates by {deg:.1e} deg"
    )
    assert f32 < 1e-7 and f64 < 1e-9 and deg < 1e-4


@pytest.mark.parametrize(
    "case, settings, tol",
    [
        ("small", {"ridge": 1e-3}, 1e-9),
        ("large", {"ridge": "auto"}, 1e-9),
        ("large", {"center": True}, 1e-9),
        # The exact fit through the Gram matrix of 288 close views: its conditioning makes the
        # sums' other order show at 2-5e-9 (one shard gives the same bits).
        ("large", {}, 1e-8),
    ],
)
def test_the_tasks_give_the_f64_model(small, large, case, settings, tol):
    """The engine's tasks run in this process, the model kept in memory: its f64 weights are the
    single-process fit's to 1e-9, for every shard count."""
    from linpose import _linpose

    X, y, params, paths = {"small": small, "large": large}[case]
    text = linpose.dask._settings(settings)
    split, units, w, h, _ = _linpose.partial_plan("linear", text, paths, y, params)
    assert (split, (h, w)) == ({"small": "images", "large": "pixels"}[case], X.shape[1:])
    want = linpose.LinearPose(params=params, **settings).fit(X, y).coef_
    worst = []
    for count in (1, 3, 8):
        parts = [_linpose.partial_read_shard(("linear", text), (paths, y, params), (w, h), (i, count)) for i in range(count)]
        while len(parts) > 1:
            parts = [_linpose.partial_merge(*parts[i : i + 2]) if i + 1 < len(parts) else parts[i] for i in range(0, len(parts), 2)]
        worst.append(_rel(want, _linpose.partial_finish(parts[0]).coefficients))
    print(f"\nlinear {settings} on {case} ({split}): f64 weights differ by {', '.join(f'{r:.1e}' for r in worst)} (1, 3, 8 shards)")
    assert max(worst) < tol


def test_shards_of_two_data_sets_with_one_manifest_do_not_merge(cli, tmp_path, monkeypatch):
    """Two objects rendered on one grid, each read by the same relative image paths from its
    own folder, as workers with each object's folder as their working directory would: the same
    names and poses, other pixels. Their shards, read as the Dask tasks read them, are refused
    when merged, naming the images; one object's shards merge."""
    from linpose import _linpose

    y = params = names = None
    for o in ("duck", "cap"):
        run(cli, "synth", "--object", o, "--azimuth", "0:355:5", "--elevation", "30", "--size", "16x12", "--out", tmp_path / o)
        _, y, params, names = linpose.read_dataset(tmp_path / o)
    text = linpose.dask._settings({"ridge": 1e-3})

    def shard(o, i):
        monkeypatch.chdir(tmp_path / o)
        _, _, w, h, _ = _linpose.partial_plan("linear", text, names, y, params)
        return _linpose.partial_read_shard(("linear", text), (names, y, params), (w, h), (i, 2))

    with pytest.raises(ValueError, match="training images .*fingerprint of the bytes"):
        _linpose.partial_merge(shard("duck", 0), shard("cap", 1))
    _linpose.partial_finish(_linpose.partial_merge(shard("duck", 0), shard("duck", 1)))


class _KillOnce(distributed.WorkerPlugin):
    """SIGKILLs the worker process when a shard task starts on a worker that already holds a
    finished shard, once (a marker file says it happened): a worker lost mid-run, with one of its
    results and the task it runs."""

    def __init__(self, marker):
        self.marker = marker

    def setup(self, worker):
        self.worker = worker

    def transition(self, key, start, finish, **kwargs):
        if finish != "executing" or "linpose-shard" not in str(key) or os.path.exists(self.marker):
            return
        done = [k for k, ts in self.worker.state.tasks.items() if "linpose-shard" in str(k) and ts.state == "memory"]
        if done:
            Path(self.marker).write_text(f"{os.getpid()} {self.worker.address} {key} {done[0]}")
            os.kill(os.getpid(), signal.SIGKILL)


def test_a_worker_killed_mid_run_changes_nothing(client, small, tmp_path):
    X, y, params, paths = small
    marker = tmp_path / "killed"
    before = set(client.run(os.getpid).values())
    client.register_plugin(_KillOnce(str(marker)), name="linpose-kill-once")
    try:
        t0 = time.perf_counter()
        with distributed.get_task_stream(client=client) as stream:
            merged = linpose.dask.fit(paths, y, client=client, params=params, shards=8, ridge=1e-3)
        dt = time.perf_counter() - t0
    finally:
        client.unregister_worker_plugin("linpose-kill-once")
    assert marker.exists(), "no worker was killed (the plugin never fired)"
    pid = int(marker.read_text().split()[0])
    assert pid in before
    client.wait_for_workers(2, timeout=30)
    assert pid not in set(client.run(os.getpid).values())
    # The shard the killed worker had summed, and the one it was reading, were summed again by
    # another worker (or by the one its nanny started, at a new address).
    _, address, reading, held = marker.read_text().split()
    ran = {t["key"]: t["worker"] for t in stream.data if "linpose-shard" in str(t["key"])}
    assert len(ran) == 8 and ran[reading] != address and ran[held] != address, (address, ran)
    single = linpose.from_bytes(linpose.LinearPose(params=params, ridge=1e-3).fit(X, y).to_bytes())
    f32, f64, deg = _compare(single, merged, X, params)
    print(
        f"\nkilled worker {pid} at {address} reading {reading}, holding {held}; fit in {dt:.2f} s;"
        f" f32 arrays differ by {f32:.1e}, f64 by {f64:.1e}, estimates by {deg:.1e} deg"
    )
    assert f32 < 1e-7 and f64 < 1e-9 and deg < 1e-4


def test_an_image_of_another_size_is_named(client, small, large, tmp_path):
    _, y, params, paths = large
    odd = tmp_path / "odd.png"
    shutil.copy(small[3][7], odd)
    bad = list(paths)
    bad[200] = str(odd)
    for method in ("linear", "eigenspace"):
        with pytest.raises(ValueError, match=r"odd\.png.*16x12|16x12.*odd\.png") as e:
            linpose.dask.fit(bad, y, client=client, method=method, params=params)
        assert "32x24" in str(e.value)
    # More images than pixels: the shard that reads it says so.
    _, y, params, paths = small
    bad = list(paths)
    bad[250] = large[3][0]
    with pytest.raises(ValueError, match=re.escape(large[3][0]) + ".*32x24"):
        linpose.dask.fit(bad, y, client=client, params=params, shards=4, ridge=1e-3)


def test_other_mistakes_are_explained(client, small):
    X, y, params, paths = small
    missing = paths[:-1] + [paths[-1] + ".gone"]
    with pytest.raises(OSError, match=r"\.gone"):
        linpose.dask.fit(missing, y, client=client, params=params, ridge=1e-3)
    with pytest.raises(ValueError, match=r"fixed --ridge"):
        linpose.dask.fit(paths, y, client=client, params=params, ridge="auto")
    with pytest.raises(ValueError, match="287 images"):
        linpose.dask.fit(paths[:-1], y, client=client, params=params)
    with pytest.raises(ValueError, match="refined"):
        linpose.dask.fit(paths, y, client=client, method="refined", params=params)
    with pytest.raises(ValueError, match="more shards than the 288 images"):
        linpose.dask.fit(paths, y, client=client, params=params, shards=289, ridge=1e-3)
    with pytest.raises(ValueError, match="components"):
        linpose.dask.fit(paths, y, client=client, method="eigenspace", params=params, components="many")
    # The tasks themselves: a shard merged twice, and statistics that miss a shard, named.
    from linpose import _linpose

    one = _linpose.partial_read_shard(("linear", [("ridge", "0.001")]), (paths, y, params), (16, 12), (0, 2))
    with pytest.raises(ValueError, match=r"shard 1/2 again.*images 0\.\.144"):
        _linpose.partial_merge(one, one, "shard 1/2", "shard 1/2 again")
    with pytest.raises(ValueError, match=r"missing images 144\.\.288"):
        _linpose.partial_finish(one)


def test_no_client_says_how_to_make_one():
    """Without client= and no current client: the error says how to make one (in a fresh
    interpreter, as this one has the module's client)."""
    import subprocess
    import sys

    code = "import linpose.dask\ntry:\n    linpose.dask.fit(['a.png'], [0.0])\nexcept ValueError as e:\n    print(e)\n"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert "needs a Dask client" in out.stdout and "Client(" in out.stdout, out.stdout + out.stderr
