"""Fusion at given poses from Python: Reconstruction.integrate_at fuses a frame where it is told
(numpy depth or a kfx.Frame), gives that pose back, fuses the map tracking made at the poses
tracking found, and refuses a pose that is not rigid."""

import numpy as np
import pytest

import kfx
from conftest import INPUT


def tracked_poses(frames):
    r = kfx.Reconstruction(kfx.open(INPUT), backend="cpu", volume_resolution=64)
    return [r.process(f).pose for f in frames]


def test_integrate_at_fuses_at_the_poses_given(frames):
    frames = frames[:8]  # enough for a map; keeps the test fast
    poses = tracked_poses(frames)
    from_arrays = kfx.Reconstruction(kfx.open(INPUT), backend="cpu", volume_resolution=64)
    from_frames = kfx.Reconstruction(kfx.open(INPUT), backend="cpu", volume_resolution=64)
    for f, pose in zip(frames, poses):
        a = from_arrays.integrate_at(np.array(f.depth), pose.astype(np.float64),
                                     colour=f.colour, stamp=f.stamp)
        b = from_frames.integrate_at(f, pose)
        for result in (a, b):
            assert result.integrated and not result.tracking_ran
            np.testing.assert_array_equal(result.pose, pose)
    a, b = from_arrays.mesh(), from_frames.mesh()
    assert len(a.vertices) > 1000
    np.testing.assert_array_equal(a.vertices, b.vertices)


def test_integrate_at_refuses_a_pose_that_is_not_rigid(frames):
    r = kfx.Reconstruction(kfx.open(INPUT), backend="cpu", volume_resolution=64)
    stretched = np.eye(4, dtype=np.float32)
    stretched[0, 0] = 2.0
    with pytest.raises(kfx.Error, match="frame 0.*pose"):
        r.integrate_at(frames[0], stretched)
    with pytest.raises(ValueError, match="4x4"):
        r.integrate_at(frames[0], np.eye(3))
    with pytest.raises(kfx.Error, match="colour"):
        r.integrate_at(frames[0], np.eye(4), colour=frames[0].colour)
    assert r.frame_count == 0
