"""Live input from OpenNI2 devices (kfx live --openni, kfx.live.run(openni=...)). No camera here:
an .oni recording written by tests/python/oni_writer.py, which OpenNI2 opens as a playback device
and plays at its recorded pace (30 Hz) as a camera would deliver its frames, stands in for one.
The frames go through the library's openni2: input, the same path a camera's take."""

import json
import math
import os
import signal
import subprocess
import sys

import numpy as np
import pytest

import kfx
import kfx.live
from conftest import kfx_cli
from oni_writer import write_oni

SETTINGS = {"volume_resolution": "64"}

pytestmark = pytest.mark.skipif(not kfx.has_openni2(), reason="kfx built without OpenNI2")


def _write(path, input_text):
    sequence = kfx.open(input_text)
    camera, frames = sequence.camera, list(sequence)
    write_oni(str(path), np.stack([f.depth for f in frames]),
              [round(f.stamp * 1e6) for f in frames], 2 * math.atan(camera.width / 2 / camera.fx),
              2 * math.atan(camera.height / 2 / camera.fy),
              colour=np.stack([f.colour for f in frames]))
    return path, len(frames)


@pytest.fixture(scope="module")
def short(tmp_path_factory):
    """8 frames of the synthetic room (0.27 s at 30 Hz; 4 tracked after exact's 4 bootstrap
    frames) and the scene's own settings."""
    text = "synthetic:frames=8,width=160,height=120"
    path, n = _write(tmp_path_factory.mktemp("openni") / "room.oni", text)
    return path, n, dict(SETTINGS, **dict(kfx.open(text).recommended_settings))


@pytest.fixture(scope="module")
def long_recording(tmp_path_factory):
    """90 frames (3 s at 30 Hz): still playing when it is stopped."""
    return _write(tmp_path_factory.mktemp("openni") / "long.oni",
                  "synthetic:frames=90,width=160,height=120")


def _rows(path):
    return np.loadtxt(path, comments="#", ndmin=2)


def _cli_env():
    return dict(os.environ, KFX_PYTHON=sys.executable, OMP_NUM_THREADS="2",
                PYTHONPATH=os.pathsep.join(p for p in sys.path if p))


def test_an_openni2_device_reads_with_the_devices_camera(short):
    path, n, _ = short
    sequence = kfx.open(f"openni2:{path}?real_time=off")
    recording = kfx.open(str(path))
    assert sequence.camera.fx == recording.camera.fx and sequence.camera.cx == 80
    assert sequence.has_colour and sequence.frame_count == n
    assert "field of view" in sequence.camera_source
    for a, b in zip(sequence, recording):
        assert (a.index, a.stamp) == (b.index, b.stamp)
        assert np.array_equal(a.depth, b.depth) and np.array_equal(a.colour, b.colour)
    # At its pace a recording's length is not known ahead: it depends on the reader's speed.
    assert kfx.open(f"openni2:{path}").frame_count == -1


def test_frame_by_frame_nothing_is_dropped_and_the_trajectory_is_kfx_runs(short, tmp_path):
    cli = kfx_cli()
    if cli is None:
        pytest.skip("the kfx CLI is not built")
    path, n, settings = short
    stats = kfx.live.run(str(tmp_path / "live"), backend="cpu", settings=settings,
                         openni=str(path), real_time=False, mesh=False)
    assert stats.stopped_by == "end of recording"
    assert (stats.frames_received, stats.frames_processed, stats.frames_dropped,
            stats.frames_missed) == (n, n, 0, 0)
    args = [a for k, v in dict(settings, colour="on").items() for a in ("--set", f"{k}={v}")]
    subprocess.run([str(cli), "run", str(path), "--out", str(tmp_path / "run"), "--backend",
                    "cpu", "-q", "--no-mesh", "--no-report"] + args, check=True)
    live, run = _rows(tmp_path / "live" / "trajectory.txt"), _rows(tmp_path / "run" /
                                                                     "trajectory.txt")
    assert live.shape == run.shape == (n, 8)
    assert np.array_equal(live, run)


def test_at_the_recorded_pace_frames_are_dropped_and_counted(short, tmp_path):
    path, n, settings = short
    results = []
    stats = kfx.live.run(str(tmp_path), backend="cpu", settings=settings, openni=str(path),
                         queue_size=2, on_frame=results.append)
    assert stats.stopped_by == "end of recording"
    # Every frame the device delivered was processed or dropped; none waits or is lost in kfx;
    # the ones OpenNI2 replaced before they were read show as gaps in the frame numbers.
    assert stats.frames_received == stats.frames_processed + stats.frames_dropped
    assert 1 <= stats.frames_received and stats.frames_received + stats.frames_missed <= n
    assert 1 <= stats.frames_processed == len(results)
    assert stats.max_queue_depth <= 2
    assert len(_rows(tmp_path / "trajectory.txt")) == stats.frames_processed
    assert (tmp_path / "mesh.ply").stat().st_size > 0
    written = json.loads((tmp_path / "stats.json").read_text())
    assert written["frames_dropped"] == stats.frames_dropped
    assert written["source"].startswith(f"OpenNI2 recording '{path}' played as a device at its "
                                        "recorded pace")


def test_kfx_live_openni_stops_on_ctrl_c_with_every_output_written(long_recording, tmp_path):
    cli = kfx_cli()
    if cli is None:
        pytest.skip("the kfx CLI is not built")
    path, n = long_recording
    out = tmp_path / "out"
    args = [str(cli), "live", "--openni", str(path), "--out", str(out), "--backend", "cpu"] + [
        a for k, v in SETTINGS.items() for a in ("--set", f"{k}={v}")]
    process = subprocess.Popen(args, env=_cli_env(), stderr=subprocess.PIPE, text=True)
    line = process.stderr.readline()
    assert "Ctrl-C stops" in line and "OpenNI2 recording" in line, line  # the device runs
    process.send_signal(signal.SIGINT)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 0, stderr
    stats = json.loads((out / "stats.json").read_text())
    assert stats["stopped_by"] == "signal SIGINT", stderr
    assert stats["frames_received"] < n
    assert stats["frames_received"] == stats["frames_processed"] + stats["frames_dropped"]
    if stats["frames_processed"]:
        assert len(_rows(out / "trajectory.txt")) == stats["frames_processed"]
        assert (out / "mesh.ply").exists()
    assert not list(out.glob("*.tmp"))


def test_a_device_that_is_not_there_is_named(tmp_path):
    missing = str(tmp_path / "none.oni")
    with pytest.raises(kfx.Error, match=rf"OpenNI2 device '{missing}'.*OpenNI2 finds these "
                                        r"devices"):
        kfx.live.run(str(tmp_path / "out"), openni=missing)
    assert not (tmp_path / "out").exists()
    with pytest.raises(kfx.Error, match=r"unknown option 'rate'"):
        kfx.open("openni2:?rate=60")
    try:
        kfx.open("openni2:")
    except kfx.Error as error:  # no camera plugged in (else the first device opened)
        assert "the first OpenNI2 device" in str(error) and "no device found" in str(error)
    cli = kfx_cli()
    if cli is None:
        pytest.skip("the kfx CLI is not built")
    result = subprocess.run([str(cli), "live", "--openni", missing, "--out", str(tmp_path / "o")],
                            env=_cli_env(), capture_output=True, text=True)
    assert result.returncode == 1
    assert f"OpenNI2 device '{missing}'" in result.stderr
    assert not (tmp_path / "o").exists()


def test_a_kfx_without_openni2_says_so(tmp_path, monkeypatch):
    """A build without OpenNI2 cannot be made here: the Python side is tested as one would
    answer (the library's own answer for openni2: inputs is tested in C++)."""
    monkeypatch.setattr(kfx, "has_openni2", lambda: False)
    with pytest.raises(kfx.Error, match=r"built without OpenNI2.*libopenni2-dev"):
        kfx.live.run(str(tmp_path / "out"), openni="")
    # Neither a RealSense camera's package nor OpenNI2: both named.
    monkeypatch.setitem(sys.modules, "pyrealsense2", None)
    with pytest.raises(kfx.Error, match=r"'pyrealsense2' \(pip install kfx\[realsense\]\).*"
                                        r"built without OpenNI2"):
        kfx.live.run(str(tmp_path / "out"))
    assert not (tmp_path / "out").exists()
