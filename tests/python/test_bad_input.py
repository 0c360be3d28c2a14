"""Bad input from Python raises a Python exception with a clear message; nothing crashes."""

import numpy as np
import pytest

import kfx
from conftest import INPUT


def test_wrong_dtype(reconstruction, frames):
    with pytest.raises(TypeError, match="uint16 .* or float32"):
        reconstruction.process(frames[0].depth.astype(np.int32))
    with pytest.raises(TypeError, match="uint16 .* or float32"):
        reconstruction.process(frames[0].depth.astype(np.float64))
    assert reconstruction.frame_count == 0


def test_wrong_shape(reconstruction):
    with pytest.raises(ValueError, match=r"2-D array \(height, width\), got shape \(120, 160, 1\)"):
        reconstruction.process(np.zeros((120, 160, 1), np.uint16))
    with pytest.raises(ValueError, match=r"got shape \(19200,\)"):
        reconstruction.process(np.zeros(160 * 120, np.uint16))


def test_not_contiguous(reconstruction, frames):
    wide = np.zeros((120, 320), np.uint16)
    with pytest.raises(ValueError, match="C-contiguous"):
        reconstruction.process(wide[:, ::2])
    with pytest.raises(ValueError, match="C-contiguous"):
        reconstruction.process(np.asfortranarray(frames[0].depth))
    assert reconstruction.frame_count == 0


def test_another_size_than_the_first(reconstruction, frames):
    reconstruction.process(frames[0])
    with pytest.raises(kfx.Error, match="frame 1: depth image is 80x60, the reconstruction was made for 160x120"):
        reconstruction.process(np.zeros((60, 80), np.uint16))
    assert reconstruction.frame_count == 1
    assert reconstruction.process(frames[1]).index == 1


@pytest.mark.parametrize("bad, words", [(np.nan, r"pixel \(7, 3\) is nan m"),
                                        (-0.25, r"pixel \(7, 3\) is -0.25 m"),
                                        (np.inf, "must be finite"),
                                        (100.0, "beyond the 65.535 m")])
def test_bad_metres(reconstruction, bad, words):
    depth = np.ones((120, 160), np.float32)
    depth[3, 7] = bad
    with pytest.raises(kfx.Error, match=words):
        reconstruction.process(depth)
    assert reconstruction.frame_count == 0


def test_bad_depth_scale(reconstruction, frames):
    with pytest.raises(kfx.Error, match="depth scale must be a positive number"):
        reconstruction.process(frames[0].depth, depth_scale=0.0)
    with pytest.raises(ValueError, match="uint16 depth only"):
        reconstruction.process(np.ones((120, 160), np.float32), depth_scale=5000.0)


def test_bad_colour(reconstruction, frames):
    depth = np.array(frames[0].depth)
    with pytest.raises(TypeError, match="colour must be a uint8"):
        reconstruction.process(depth, colour=np.zeros((120, 160, 3), np.float32))
    with pytest.raises(ValueError, match=r"\(height, width, 3\)"):
        reconstruction.process(depth, colour=np.zeros((120, 160), np.uint8))
    with pytest.raises(ValueError, match="does not match the depth"):
        reconstruction.process(depth, colour=np.zeros((60, 80, 3), np.uint8))
    # The synthetic room has colour, so the map fuses it: a frame must bring its colour.
    with pytest.raises(kfx.Error, match="the map fuses colour"):
        reconstruction.process(depth)
    grey = kfx.Reconstruction(kfx.open("synthetic:frames=2,width=160,height=120"),
                              backend="cpu", volume_resolution=64, colour="off")
    # Colour off: a colour image passed in would be dropped, so it is an error naming the setting.
    with pytest.raises(kfx.Error, match="frame 0: a colour image was given.*colour=off"):
        grey.process(depth, colour=np.zeros((120, 160, 3), np.uint8))
    assert grey.frame_count == 0
    grey.process(frames[0])  # a frame the sequence read: its colour is the input's, not used
    assert grey.mesh().colours is None


def test_bad_stamps(frames):
    r = kfx.Reconstruction(kfx.open("synthetic:frames=2,width=160,height=120"),
                           backend="cpu", volume_resolution=64, colour="off")
    depth = np.array(frames[0].depth)
    with pytest.raises(kfx.Error, match="frame 0: time stamp nan s is not a finite number"):
        r.process(depth, stamp=float("nan"))
    with pytest.raises(kfx.Error, match="time stamp inf s is not a finite number"):
        r.process(depth, stamp=float("inf"))
    r.process(depth, stamp=2.0)
    with pytest.raises(kfx.Error, match="frame 1: time stamp 1 s is earlier than"):
        r.process(depth, stamp=1.0)
    assert r.frame_count == 1


def test_unknown_setting():
    with pytest.raises(kfx.Error, match="unknown setting 'volume_resolutoin'"):
        kfx.Reconstruction(kfx.open(INPUT), backend="cpu", volume_resolutoin=64)
    with pytest.raises(kfx.Error, match="volume_resolution"):
        kfx.Reconstruction(kfx.open(INPUT), backend="cpu", volume_resolution="many")
    with pytest.raises(kfx.Error, match="preset"):
        kfx.Reconstruction(kfx.open(INPUT), preset="exactly")
    with pytest.raises(kfx.Error, match="backend"):
        kfx.Reconstruction(kfx.open(INPUT), backend="tpu")
    with pytest.raises(kfx.Error, match="give a sequence, a camera"):
        kfx.Reconstruction(backend="cpu")


def test_bad_inputs_and_poses(reconstruction):
    with pytest.raises(kfx.Error, match="no_such_folder"):
        kfx.open("/no_such_folder")
    with pytest.raises(ValueError, match="4x4"):
        reconstruction.render(np.eye(3))
    with pytest.raises(kfx.Error, match="collect"):
        reconstruction.collect()
    with pytest.raises(TypeError):
        reconstruction.process([[1, 2], [3, 4]])
