"""Issue 46: the live view. A reconstruction streamed to a Rerun .rrd file, read back with the
Rerun SDK: the camera's poses are the trajectory's, every one of them; a view slower than the
frame loop skips frames' images rather than holding the loop up, and still logs every pose."""

import time

import numpy as np
import pytest

import kfx
from conftest import INPUT

rr = pytest.importorskip("rerun", reason="rerun-sdk (pip install kfx[viewer])")


def _table(path, index, contents):
    """The recording's columns (but its wall-clock log_time) as lists, one row per `index`."""
    table = rr.dataframe.load_recording(str(path)).view(
        index=index, contents=contents).select().read_all()
    return table.drop([name for name in table.column_names if name == "log_time"]).to_pydict()


def _run(viewer, frames=None, wait_for_view=False):
    sequence = kfx.open(INPUT)
    r = kfx.Reconstruction(sequence, backend="cpu", volume_resolution=64)
    for n, frame in enumerate(sequence):
        if frames is not None and n == frames:
            break
        viewer.submit(r, frame, r.process(frame))
        if wait_for_view:
            viewer.flush()  # every frame in the view, however busy the machine
        else:
            time.sleep(0.02)  # a camera's pace
    return r, viewer.close()


def test_the_view_streams_poses_depth_colour_and_the_model(tmp_path):
    from kfx.viewer import Viewer  # noqa: PLC0415

    path = tmp_path / "live.rrd"
    r, stats = _run(Viewer(str(path), images_every_s=0.0, model_every_s=0.0,
                           mesh_every_s=0.0, budget=1.0), wait_for_view=True)
    assert stats["frames_logged"] == len(r.poses())
    assert stats["frames_skipped"] == 0
    assert stats["poses_logged"] == len(r.poses())
    assert stats["meshes"] == 1  # the final one (mesh_every_s=0: none while running)
    table = _table(path, "frame", "/**")
    poses = r.poses()
    logged = 0
    for frame, translation in zip(table["frame"], table["/world/camera:Translation3D"]):
        if translation is None:
            continue
        logged += 1
        assert np.allclose(translation[0], poses[frame][:3, 3], atol=1e-6)
    assert logged == len(poses)  # every pose, the skipped frames' too
    for column in ("/camera/depth:ImageBuffer", "/camera/colour:ImageBuffer",
                   "/camera/model_render:ImageBuffer", "/world/model_view:Position3D"):
        assert sum(v is not None for v in table[column]) == stats["frames_logged"], column
    static = _table(path, "log_tick", "/world/model")
    assert any(v is not None for v in static["/world/model:Position3D"])


def test_a_slow_view_skips_frames_and_never_holds_the_loop(tmp_path):
    from kfx.viewer import Viewer  # noqa: PLC0415

    path = tmp_path / "slow.rrd"
    # Each update takes the viewer process half a second: far slower than the loop.
    viewer = Viewer(str(path), images_every_s=0.0, model_every_s=3600.0, mesh_every_s=-1,
                    _log_delay_s=0.5)
    r, stats = _run(viewer, frames=12)
    assert stats["frames_skipped"] > 0
    assert stats["frames_logged"] + stats["frames_skipped"] + stats["frames_between"] == 12
    # submit() never waited for the half-second logs.
    assert stats["submit_seconds"] < 0.25
    # The poses of skipped frames went with later updates: the path is whole.
    assert stats["poses_logged"] == 12
    table = _table(path, "frame", "/world/camera")
    logged = [f for f, t in zip(table["frame"], table["/world/camera:Translation3D"])
              if t is not None]
    assert logged == list(range(12))
