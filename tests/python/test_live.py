"""Issue 46: live input. No camera here: a RealSense recording of icl_office_kt0 frames, made at
30 Hz by pyrealsense2's recorder and played back by pyrealsense2 at real time, stands in for
one. The reconstruction (on the CPU, slower than the camera) drops frames from a bounded queue
and counts them; Ctrl-C stops it with every output written."""

import json
import os
import signal
import subprocess
import sys
import threading
import time
from types import SimpleNamespace

import numpy as np
import pytest

from conftest import SHARED, kfx_cli

FOLDER = SHARED / "data" / "icl_office_kt0"
FRAMES = 45  # 1.5 s at 30 Hz
SETTINGS = {"volume_resolution": "64", "compute_size_ratio": "2"}


@pytest.fixture(scope="module")
def paced_recording(tmp_path_factory):
    if not FOLDER.is_dir():
        pytest.skip(f"{FOLDER} not present")
    pytest.importorskip("pyrealsense2", reason="pyrealsense2 (pip install kfx[realsense])")
    import kfx.recordings  # noqa: PLC0415

    path = tmp_path_factory.mktemp("live") / "camera.db3"
    kfx.recordings.write_realsense_bag(str(FOLDER), str(path), FRAMES, fps=30, paced=True)
    return path


def _trajectory_rows(path):
    return [line for line in path.read_text().splitlines() if line and not line.startswith("#")]


def test_live_keeps_up_by_dropping_and_counting_frames(paced_recording, tmp_path):
    import kfx.live  # noqa: PLC0415

    results = []
    stats = kfx.live.run(str(tmp_path), str(paced_recording), backend="cpu", settings=SETTINGS,
                         queue_size=2, on_frame=results.append)
    assert stats.stopped_by == "end of recording"
    # Every frame the camera delivered was processed or dropped; none waits or is lost in kfx.
    assert stats.frames_received == stats.frames_processed + stats.frames_dropped
    assert 2 <= stats.frames_received and stats.frames_received + stats.frames_missed <= FRAMES
    assert 1 <= stats.frames_processed == len(results)
    assert stats.max_queue_depth <= 2
    assert len(_trajectory_rows(tmp_path / "trajectory.txt")) == stats.frames_processed
    assert (tmp_path / "mesh.ply").stat().st_size > 0
    written = json.loads((tmp_path / "stats.json").read_text())
    assert written["frames_dropped"] == stats.frames_dropped
    assert written["queue_size"] == 2


def test_live_as_fast_as_read_processes_every_frame(paced_recording, tmp_path):
    """Without the camera's pace the player waits for kfx: nothing is dropped, and the frames
    are the recording's (their stamps: 1/30 s apart)."""
    import kfx.live  # noqa: PLC0415

    stamps = []
    stats = kfx.live.run(str(tmp_path), str(paced_recording), backend="cpu", settings=SETTINGS,
                         frames=5, real_time=False, mesh=False, colour=False,
                         on_frame=lambda r: stamps.append(r.stamp))
    assert stats.frames_processed == 5 and stats.stopped_by == "frame limit"
    assert not (tmp_path / "mesh.ply").exists()
    assert np.allclose(np.diff(stamps), 1 / 30, atol=1e-6)


def test_kfx_live_stops_on_ctrl_c_with_every_output_written(paced_recording, tmp_path):
    cli = kfx_cli()
    if cli is None:
        pytest.skip("the kfx CLI is not built")
    out = tmp_path / "out"
    env = dict(os.environ, KFX_PYTHON=sys.executable, OMP_NUM_THREADS="2",
               PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    args = [str(cli), "live", "--out", str(out), "--from-file", str(paced_recording),
            "--backend", "cpu"] + [a for k, v in SETTINGS.items() for a in ("--set", f"{k}={v}")]
    process = subprocess.Popen(args, env=env, stderr=subprocess.PIPE, text=True)
    assert "Ctrl-C stops" in process.stderr.readline()  # the camera runs
    time.sleep(0.3)
    process.send_signal(signal.SIGINT)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 0, stderr
    stats = json.loads((out / "stats.json").read_text())
    assert stats["stopped_by"] == "signal SIGINT", stderr
    assert stats["frames_received"] < FRAMES
    assert stats["frames_received"] == stats["frames_processed"] + stats["frames_dropped"]
    if stats["frames_processed"]:
        assert len(_trajectory_rows(out / "trajectory.txt")) == stats["frames_processed"]
        assert (out / "mesh.ply").exists()
    assert not list(out.glob("*.tmp"))


def test_kfx_live_names_a_missing_recording(tmp_path):
    cli = kfx_cli()
    if cli is None:
        pytest.skip("the kfx CLI is not built")
    pytest.importorskip("pyrealsense2", reason="pyrealsense2 (pip install kfx[realsense])")
    env = dict(os.environ, KFX_PYTHON=sys.executable,
               PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    result = subprocess.run([str(cli), "live", "--out", str(tmp_path / "out"), "--from-file",
                             str(tmp_path / "none.db3")], env=env, capture_output=True, text=True)
    assert result.returncode == 1
    assert f"recording '{tmp_path / 'none.db3'}' does not exist" in result.stderr


def test_kfx_live_says_which_dependency_is_missing(tmp_path, monkeypatch):
    import kfx  # noqa: PLC0415
    import kfx.live  # noqa: PLC0415

    monkeypatch.setitem(sys.modules, "pyrealsense2", None)  # as if not installed
    with pytest.raises(kfx.Error, match=r"needs the PyPI package 'pyrealsense2' \(pip install "
                                        r"kfx\[realsense\]\)"):
        kfx.live.run(str(tmp_path / "out"))
    assert not (tmp_path / "out").exists()
    cli = kfx_cli()
    if cli is None:
        pytest.skip("the kfx CLI is not built")
    missing = str(tmp_path / "no-python")
    result = subprocess.run([str(cli), "live", "--out", str(tmp_path / "out")],
                            env=dict(os.environ, KFX_PYTHON=missing), capture_output=True,
                            text=True)
    assert result.returncode == 1
    assert f"cannot run '{missing}'" in result.stderr and "KFX_PYTHON" in result.stderr


class _RealSenseWithoutCamera:
    """pyrealsense2 as it behaves with no camera plugged in: the pipeline refuses to start."""

    class stream:  # noqa: N801 (pyrealsense2's names)
        depth, color = "depth", "color"

    class format:  # noqa: N801
        z16, rgb8 = "z16", "rgb8"

    class config:  # noqa: N801
        def enable_stream(self, *args):
            pass

        def enable_device(self, serial):
            pass

    class pipeline:  # noqa: N801
        def start(self, config):
            raise RuntimeError("No device connected")


@pytest.mark.parametrize("realsense, args, said", [
    (_RealSenseWithoutCamera, [], "cannot start a RealSense camera: No device connected"),
    (_RealSenseWithoutCamera, ["--from-file", "none.db3"], "recording 'none.db3' does not exist"),
    (_RealSenseWithoutCamera, ["--queue", "0"], "the queue holds at least one frame"),
    (None, [], "a RealSense camera needs the PyPI package 'pyrealsense2'"),  # not installed
])
def test_kfx_live_says_an_error_once_after_its_prefix(tmp_path, monkeypatch, capsys, realsense,
                                                      args, said):
    import kfx.live  # noqa: PLC0415

    monkeypatch.setitem(sys.modules, "pyrealsense2", realsense)
    # main() would take SIGINT and SIGTERM from pytest for the rest of the session.
    monkeypatch.setattr(kfx.live, "_StopOnSignal", lambda: SimpleNamespace(event=threading.Event()))
    monkeypatch.chdir(tmp_path)
    assert kfx.live.main(["--out", str(tmp_path / "out")] + args) == 1
    err = capsys.readouterr().err
    assert err.startswith(f"kfx live: error: {said}") and err.count("kfx live:") == 1, err
