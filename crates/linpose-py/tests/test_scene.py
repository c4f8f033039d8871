"""Scenes from Python: ``linpose.synth(background=..., occlude=...)`` and ``linpose.scene``, the
same scenes the command line makes, the object found as the renderer drew it, and bad
arguments refused by name."""

import numpy as np
import PIL.Image
import pytest

import linpose
from conftest import run

GRID = dict(azimuth="0:330:30", elevation="40", size=(64, 48))


def test_synth_in_a_scene_is_what_the_command_writes(cli, tmp_path):
    out = tmp_path / "set"
    run(cli, "synth", "--object", "duck", "--out", out, "--azimuth", "0:330:30", "--elevation", "40", "--size", "64x48",
        "--background", "texture", "--occlude", "0.2", "--seed", "3")
    images, poses, params, info = linpose.synth("duck", background="texture", occlude=0.2, scene_seed=3, return_scene=True, **GRID)
    read, read_poses, _, names = linpose.read_dataset(out)
    assert np.array_equal(read, images) and np.array_equal(read_poses, poses)
    csv = (out / "scene.csv").read_text().splitlines()
    assert len(csv) == 13 and len(info["records"]) == 12
    for line, record in zip(csv[1:], info["records"]):
        assert line.split(",")[0] == record["image"]
        assert float(line.split(",")[4]) == record["hidden"]
    assert np.all(np.abs(info["hidden"] - 0.2) < 0.04), info["hidden"]
    # The hidden share is the share of the mask the occluders cover.
    shares = (info["mask"] & info["occluded"]).sum(axis=(1, 2)) / info["mask"].sum(axis=(1, 2))
    assert np.allclose(shares, info["hidden"])
    # Without return_scene, the same images and the usual three items.
    again = linpose.synth("duck", background="texture", occlude=0.2, scene_seed=3, **GRID)
    assert len(again) == 3 and np.array_equal(again[0], images)


def test_the_object_keeps_its_pixels_and_a_level_is_the_studio():
    studio, _, _ = linpose.synth("pot", **GRID)
    white, _, _ = linpose.synth("pot", background=1.0, **GRID)
    whole = studio == white
    scene, _, _, info = linpose.synth("pot", background="noise", occlude=0.3, scene_seed=1, return_scene=True, **GRID)
    keep = whole & ~info["occluded"]
    assert keep.sum() > 3000 and np.array_equal(scene[keep], studio[keep])
    level, _, _, info = linpose.synth("pot", background=0.5, return_scene=True, **GRID)
    assert np.array_equal(level, linpose.synth("pot", background=0.5, **GRID)[0])
    assert info["records"] == [] and not info["occluded"].any() and info["mask"].any()


def test_scene_finds_the_rendered_object_and_draws_per_seed():
    studio, _, _, truth = linpose.synth("duck", background=0.3, return_scene=True, **GRID)
    out, info = linpose.scene(studio, occlude=0.25, seed=2)
    assert out.shape == studio.shape and out.dtype == np.uint8
    both = (info["mask"] & truth["mask"]).sum(axis=(1, 2))
    either = (info["mask"] | truth["mask"]).sum(axis=(1, 2))
    assert np.all(both / either > 0.95), both / either
    assert np.all(np.abs(info["hidden"] - 0.25) < 0.04), info["hidden"]
    assert info["records"][3]["image"] == "image 3"
    assert info["records"][0]["occluders"][0][0] in ("rect", "ellipse")
    again, _ = linpose.scene(studio, occlude=0.25, seed=2)
    other, _ = linpose.scene(studio, occlude=0.25, seed=3)
    assert np.array_equal(out, again) and not np.array_equal(out, other)
    # Colour views stay colour.
    rgb = np.repeat(studio[..., None], 3, axis=3)
    out3, _ = linpose.scene(rgb, background="texture")
    assert out3.shape == rgb.shape and (out3[..., 0] != out3[..., 1]).any()


def test_photographs_and_bad_arguments(tmp_path):
    photos = tmp_path / "photos"
    photos.mkdir()
    PIL.Image.fromarray(np.random.default_rng(0).integers(0, 255, (120, 160, 3), dtype=np.uint8)).save(photos / "street.png")
    _, _, _, info = linpose.synth("cap", background=photos, return_scene=True, **GRID)
    assert all(r["background"].startswith("photo street.png ") for r in info["records"])
    studio, _, _ = linpose.synth("cap", **GRID)
    for bad in ("1", "-0.5"):
        with pytest.raises(ValueError, match=f"occlude = {bad}:"):
            linpose.scene(studio, occlude=float(bad))
        with pytest.raises(ValueError, match=f"occlude = {bad}:"):
            linpose.synth("cap", occlude=float(bad), **GRID)
    with pytest.raises(ValueError, match="background = nowhere"):
        linpose.scene(studio, background="nowhere")
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(ValueError, match="no photographs"):
        linpose.synth("cap", background=empty, **GRID)
    blank = studio.copy()
    blank[5] = 0
    with pytest.raises(ValueError, match="image 5: no separable object"):
        linpose.scene(blank)
    with pytest.raises(ValueError, match="shape"):
        linpose.scene(studio[0])
    with pytest.raises(TypeError, match="uint8"):
        linpose.scene(studio.astype(np.float32))


def test_the_robust_stage_reads_scenes_and_leaves_studio_views_as_they_are(tmp_path):
    # The duck every 10 degrees, queried between its training views: over texture with a fifth
    # hidden, and in the studio.
    grid = dict(elevation="40", size=(64, 48))
    X, y, params = linpose.synth("duck", azimuth="0:350:10", **grid)
    studio, truth, _ = linpose.synth("duck", azimuth="5:355:20", **grid)
    scenes, _, _ = linpose.synth("duck", azimuth="5:355:20", background="texture", occlude=0.2, scene_seed=1, **grid)
    plain = linpose.EigenspacePose(params=params, normalize="off").fit(X, y)
    robust = linpose.EigenspacePose(params=params, normalize="off", robust=True).fit(X, y)
    assert robust.get_params()["robust"] is True and robust.model_.robust and not plain.model_.robust
    err = lambda m, Q: float(np.mean(np.abs((m.predict(Q) - truth + 180) % 360 - 180)))
    assert err(robust, scenes) < 3.0 and err(plain, scenes) > 5 * err(robust, scenes), (err(plain, scenes), err(robust, scenes))
    assert np.array_equal(robust.predict(studio), plain.predict(studio))
    # The stage survives the model file and pickling; a model read back says it has it.
    path = tmp_path / "r.safetensors"
    robust.save(path)
    back = linpose.load(path)
    assert back.robust is True and np.array_equal(back.predict(scenes), robust.predict(scenes))
    import pickle

    again = pickle.loads(pickle.dumps(robust))
    assert np.array_equal(again.predict(scenes), robust.predict(scenes))
