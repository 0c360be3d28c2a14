"""Issue 24's goal on the CPU backend: one sequence through the CLI (`kfx run`), the C++ API
(tests/tools/api_trajectory.cpp, linked with the SLAM library alone) and Python gives
byte-identical trajectory files. The synthetic room everywhere; the shared sequences where
present (their first frames, to keep the test short)."""

import os
import pathlib
import subprocess

import pytest

import kfx
from conftest import INPUT, ROOT, SHARED, kfx_cli

# (input, frames (0: all), settings): the same for all three.
CASES = [(INPUT, 0, {"volume_resolution": 64})]
for name in ("tum_fr1_xyz", "icl_office_kt0"):
    CASES.append((str(SHARED / "data" / name), 40, {"volume_resolution": 128}))


def api_tool():
    """kfx_api_trajectory built beside the CLI (KFX_API_TRAJECTORY, else build/release/tests/)."""
    path = pathlib.Path(os.environ.get("KFX_API_TRAJECTORY",
                                       ROOT / "build" / "release" / "tests" / "kfx_api_trajectory"))
    return path if path.exists() else None


def python_trajectory(input, frames, settings, path):
    """As `kfx run` feeds the frames: one in flight."""
    sequence = kfx.open(input)
    r = kfx.Reconstruction(sequence, backend="cpu", **settings)
    for n, frame in enumerate(sequence):
        if frames and n == frames:
            break
        r.submit(frame)
        if r.frames_in_flight > 1:
            r.collect()
    while r.frames_in_flight:
        r.collect()
    r.save_trajectory(str(path))  # names the sequence in its header, as kfx run


@pytest.mark.parametrize("input, frames, settings", CASES,
                         ids=[pathlib.Path(c[0]).name.split(":")[0] for c in CASES])
def test_cli_cpp_api_and_python_trajectories_are_byte_identical(tmp_path, input, frames,
                                                                settings):
    if not input.startswith("synthetic") and not os.path.isdir(input):
        pytest.skip(f"{input} not present")
    cli, tool = kfx_cli(), api_tool()
    if cli is None or tool is None:
        pytest.skip("the kfx CLI and kfx_api_trajectory are not built (scripts/build)")
    pairs = [f"{k}={v}" for k, v in settings.items()]
    limit = ["--frames", str(frames)] if frames else []
    subprocess.run([str(cli), "run", input, "--backend", "cpu", "-q", "--no-mesh", "--no-report",
                    "--out", str(tmp_path / "cli")] + limit
                   + [a for p in pairs for a in ("--set", p)], check=True, capture_output=True)
    subprocess.run([str(tool), input, str(tmp_path / "api.txt"), "--backend", "cpu"] + limit
                   + pairs, check=True, capture_output=True)
    python_trajectory(input, frames, settings, tmp_path / "py.txt")

    expected = (tmp_path / "cli" / "trajectory.txt").read_bytes()
    poses = [line for line in expected.decode().splitlines() if not line.startswith("#")]
    assert len(poses) == (frames or 24)
    # The camera moved: identical files of a camera that stood still would prove little.
    assert poses[0].split()[1:4] != poses[-1].split()[1:4]
    assert (tmp_path / "api.txt").read_bytes() == expected, "C++ API differs from kfx run"
    assert (tmp_path / "py.txt").read_bytes() == expected, "Python differs from kfx run"
