"""OpenNI2 .oni recordings as inputs, read through OpenNI2's own player. No camera or recorder is
here, so tests/python/oni_writer.py writes the recordings from synthetic frames (uncompressed, as
the format allows); the player reading them back frame for frame is what is tested."""

import math
import subprocess

import numpy as np
import pytest

import kfx
from conftest import kfx_cli
from oni_writer import write_oni

INPUT = "synthetic:frames=12,width=160,height=120"


def _openni_built():
    try:
        kfx.open("/nonexistent.oni")
    except kfx.Error as error:
        return "built without OpenNI2" not in str(error)
    return True


pytestmark = pytest.mark.skipif(not _openni_built(), reason="kfx built without OpenNI2")


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    sequence = kfx.open(INPUT)
    camera, frames = sequence.camera, list(sequence)
    path = tmp_path_factory.mktemp("oni") / "camera.oni"
    write_oni(str(path), np.stack([f.depth for f in frames]),
              [round(f.stamp * 1e6) for f in frames], 2 * math.atan(camera.width / 2 / camera.fx),
              2 * math.atan(camera.height / 2 / camera.fy),
              colour=np.stack([f.colour for f in frames]))
    return path, camera, frames


def test_an_oni_recording_reads_as_its_frames_with_its_camera(recording):
    path, camera, frames = recording
    sequence = kfx.open(str(path))
    assert sequence.frame_count == len(frames)
    # Intrinsics from the recorded field of view; the centre where OpenNI2 puts it.
    assert sequence.camera.fx == pytest.approx(camera.fx, rel=1e-5)
    assert sequence.camera.fy == pytest.approx(camera.fy, rel=1e-5)
    assert (sequence.camera.cx, sequence.camera.cy) == (camera.width / 2, camera.height / 2)
    got = list(sequence)
    assert len(got) == len(frames)
    for a, b in zip(got, frames):
        assert np.array_equal(a.depth, b.depth)  # millimetres, bit for bit
        assert np.array_equal(a.colour, b.colour)
        assert a.stamp == pytest.approx(b.stamp, abs=1e-6)


def test_the_cli_runs_an_oni_recording_as_the_same_frames(recording, tmp_path):
    cli = kfx_cli()
    if cli is None:
        pytest.skip("no kfx CLI built")
    path, camera, _ = recording
    common = ["--backend", "cpu", "--set", "volume_resolution=64", "-q"]
    # The synthetic scene's own settings (its volume, its start) for the recording of it too.
    scene = [arg for key, value in kfx.open(INPUT).recommended_settings
             for arg in ("--set", f"{key}={value}")]
    subprocess.run([str(cli), "run", str(path), "--out", str(tmp_path / "oni")] + common + scene,
                   check=True)
    subprocess.run([str(cli), "run", INPUT, "--out", str(tmp_path / "synthetic"),
                    "--set", f"camera={camera.fx},{camera.fy},{camera.width / 2},"
                    f"{camera.height / 2}"] + common, check=True)

    def rows(folder):
        return np.loadtxt(folder / "trajectory.txt", comments="#")

    oni, synthetic = rows(tmp_path / "oni"), rows(tmp_path / "synthetic")
    assert oni.shape == synthetic.shape
    assert np.abs(oni[:, 1:4] - synthetic[:, 1:4]).max() < 1e-5  # 0.01 mm


def test_bad_oni_recordings_name_the_file_and_the_problem(recording, tmp_path):
    path, camera, frames = recording
    depth = np.stack([f.depth for f in frames[:3]])
    stamps = [0, 33333, 66666]
    truncated = tmp_path / "truncated.oni"
    write_oni(str(truncated), depth, stamps, 1.0, 0.8, truncate_last=2000)
    with pytest.raises(kfx.Error, match=r"truncated\.oni.*depth frame 2 of 3"):
        list(kfx.open(str(truncated)))
    no_fov = tmp_path / "no_fov.oni"
    write_oni(str(no_fov), depth, stamps, 0.0, 0.0)
    with pytest.raises(kfx.Error, match=r"no_fov\.oni.*intrinsics missing"):
        kfx.open(str(no_fov))
    garbage = tmp_path / "garbage.oni"
    garbage.write_bytes(b"not a recording" * 10)
    with pytest.raises(kfx.Error, match=r"garbage\.oni"):
        kfx.open(str(garbage))
