"""``linpose.synth`` with roll and light: the pose columns and their parameters, roll 0 as no
roll, the light changing the shading but not the silhouette, the images the command line writes,
and bad specs refused by name."""

import numpy as np
import PIL.Image
import pytest

import linpose
from conftest import run


def test_roll_and_light_add_pose_columns():
    images, poses, params = linpose.synth("duck", azimuth="0:90:45", elevation="40", roll="-20:20:20", light="0:270:90", size=(32, 24))
    assert images.shape == (3 * 3 * 4, 24, 32) and images.dtype == np.uint8
    assert poses.shape == (36, 4)
    # A partial roll is linear, a light grid round the whole turn circular.
    assert [tuple(p) for p in params] == [("elevation", None), ("azimuth", 360.0), ("roll", None), ("light", 360.0)]
    # The last column varies fastest.
    assert poses[:5].tolist() == [[40, 0, -20, 0], [40, 0, -20, 90], [40, 0, -20, 180], [40, 0, -20, 270], [40, 0, 0, 0]]
    _, _, params = linpose.synth("duck", azimuth="0", elevation="40", roll="0:300:60", size=(8, 8))
    assert [tuple(p) for p in params][2] == ("roll", 360.0)


def test_roll_0_is_no_roll_and_the_light_keeps_the_silhouette():
    plain, poses, _ = linpose.synth("pot", azimuth="0:300:60", elevation="40", size=(40, 30))
    zero, rolled, _ = linpose.synth("pot", azimuth="0:300:60", elevation="40", roll="0", size=(40, 30))
    assert np.array_equal(plain, zero) and np.array_equal(poses, rolled[:, :2])
    lit, _, _ = linpose.synth("pot", azimuth="0:300:60", elevation="40", light="0:180:180", size=(40, 30))
    assert np.array_equal(lit[0::2] > 0, lit[1::2] > 0)
    assert np.array_equal(lit[0::2] > 0, plain > 0)
    assert (lit[0::2] != lit[1::2]).sum() > 0.2 * (plain > 0).sum()


def test_the_images_are_those_the_command_writes(cli, tmp_path):
    out = tmp_path / "set"
    run(cli, "synth", "--object", "cap", "--out", out, "--azimuth", "0:90:90", "--elevation", "40", "--roll", "-30:30:30", "--light", "0:180:90", "--size", "32x24")
    images, poses, _ = linpose.synth("cap", azimuth="0:90:90", elevation="40", roll="-30:30:30", light="0:180:90", size=(32, 24))
    read, read_poses, params, names = linpose.read_dataset(out)
    assert np.array_equal(read, images) and np.array_equal(read_poses, poses)
    assert [p[0] for p in params] == ["elevation", "azimuth", "roll", "light"]
    assert np.array_equal(np.asarray(PIL.Image.open(out / names[0])), images[0])


def test_bad_roll_and_light_are_named():
    with pytest.raises(ValueError, match="roll = 0:10:0"):
        linpose.synth("duck", azimuth="0", elevation="40", roll="0:10:0", size=(8, 8))
    with pytest.raises(ValueError, match="light = x"):
        linpose.synth("duck", azimuth="0", elevation="40", light="x", size=(8, 8))
