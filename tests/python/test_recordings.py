"""Issue 46: recordings as inputs. The first frames of icl_office_kt0, with colour, recorded by
the libraries that write them in the field (rosbags: ROS 1 bags plain and bz2/lz4-compressed,
a ROS 2 bag; pyrealsense2's software device and recorder: a RealSense recording in its current
ROS 2 form and, with the older pyrealsense2 scripts/test installs beside it, its ROS 1 .bag
form), give the folder's frames, and through the CLI and Python its trajectory (to 0.01 mm)
and coloured mesh."""

import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

import kfx
from conftest import ROOT, SHARED, kfx_cli

FOLDER = SHARED / "data" / "icl_office_kt0"
FRAMES = 8
# Small and quick; the same for the folder and every recording.
SETTINGS = {"volume_resolution": 128, "compute_size_ratio": 2}
# The older pyrealsense2 whose recorder writes ROS 1 .bag files (scripts/test installs it here).
REALSENSE_BAG_PACKAGE = pathlib.Path(
    os.environ.get("KFX_PYREALSENSE2_BAG", ROOT / "build" / "pyrealsense2-bag"))

FORMATS = ["ros1", "ros1-bz2", "ros1-lz4", "ros2", "realsense", "realsense-bag"]
# Runs take longer than reads: the compressed ROS 1 bags, whose frames read the same as the
# plain one's (test_recording_reads_as_the_folders_frames), are not run again.
RUN_FORMATS = ["ros1", "ros2", "realsense", "realsense-bag"]


def _write(kind, path):
    """Records FRAMES frames of the folder as `kind` at `path`; skips when a writer is missing."""
    if not FOLDER.is_dir():
        pytest.skip(f"{FOLDER} not present")
    import kfx.recordings as recordings  # noqa: PLC0415 (needs the optional writers)

    if kind.startswith("ros"):
        pytest.importorskip("rosbags", reason="rosbags (pip install kfx[ros]) writes ROS bags")
    if kind == "ros2":
        recordings.write_ros2_bag(str(FOLDER), str(path), FRAMES)
    elif kind.startswith("ros1"):
        compression = kind.split("-")[1] if "-" in kind else "none"
        recordings.write_ros1_bag(str(FOLDER), str(path), FRAMES, compression=compression)
    elif kind == "realsense":
        pytest.importorskip("pyrealsense2", reason="pyrealsense2 (pip install kfx[realsense])")
        recordings.write_realsense_bag(str(FOLDER), str(path), FRAMES)
    else:
        if not (REALSENSE_BAG_PACKAGE / "pyrealsense2").is_dir():
            pytest.skip(f"the pyrealsense2 that writes .bag files is not at "
                        f"{REALSENSE_BAG_PACKAGE} (scripts/test installs it)")
        # A process of its own: that pyrealsense2 cannot share one with the current one.
        env = dict(os.environ, PYTHONPATH=os.pathsep.join(
            [str(REALSENSE_BAG_PACKAGE)] + [p for p in sys.path if p]))
        subprocess.run([sys.executable, "-c",
                        "import sys, kfx.recordings as r; "
                        "r.write_realsense_bag(sys.argv[1], sys.argv[2], int(sys.argv[3]))",
                        str(FOLDER), str(path), str(FRAMES)], env=env, check=True,
                       capture_output=True)


@pytest.fixture(scope="module")
def recordings_dir(tmp_path_factory):
    return tmp_path_factory.mktemp("recordings")


@pytest.fixture(scope="module")
def recording(recordings_dir, request):
    kind = request.param
    suffix = {"ros2": "", "realsense": ".db3", "realsense-bag": ".bag"}.get(kind, ".bag")
    path = recordings_dir / (kind + suffix)
    _write(kind, path)
    return path


def _rows(trajectory_file):
    rows = [line.split() for line in pathlib.Path(trajectory_file).read_text().splitlines()
            if line and not line.startswith("#")]
    return np.array(rows, dtype=np.float64)


def _mesh_body(path):
    """mesh.ply without its comment lines (they name the input)."""
    data = pathlib.Path(path).read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = b"".join(line for line in data[:end].splitlines(keepends=True)
                      if not line.startswith(b"comment"))
    return header + data[end:]


def _run_cli(input, out):
    cli = kfx_cli()
    if cli is None:
        pytest.skip("the kfx CLI is not built")
    args = [str(cli), "run", str(input), "--backend", "cpu", "-q", "--no-report", "--frames",
            str(FRAMES), "--out", str(out)]
    for key, value in SETTINGS.items():
        args += ["--set", f"{key}={value}"]
    subprocess.run(args, check=True, capture_output=True,
                   env=dict(os.environ, OMP_NUM_THREADS="2"))
    return out


def _run_python(input):
    sequence = kfx.open(str(input))
    r = kfx.Reconstruction(sequence, backend="cpu", **SETTINGS)
    for n, frame in enumerate(sequence):
        if n == FRAMES:
            break
        r.process(frame)
    return r


@pytest.fixture(scope="module")
def folder_cli(tmp_path_factory):
    if not FOLDER.is_dir():
        pytest.skip(f"{FOLDER} not present")
    return _run_cli(FOLDER, tmp_path_factory.mktemp("folder") / "run")


@pytest.fixture(scope="module")
def folder_python():
    if not FOLDER.is_dir():
        pytest.skip(f"{FOLDER} not present")
    return _run_python(FOLDER)


@pytest.mark.parametrize("recording", FORMATS, indirect=True)
def test_recording_reads_as_the_folders_frames(recording):
    folder = kfx.open(str(FOLDER))
    recorded = kfx.open(str(recording))
    assert recorded.frame_count == FRAMES
    assert (recorded.width, recorded.height) == (folder.width, folder.height)
    for k in ("fx", "fy", "cx", "cy"):
        assert getattr(recorded.camera, k) == getattr(folder.camera, k)
    for expected, got in zip(folder, recorded):
        assert got.stamp == expected.stamp
        assert np.array_equal(got.depth, expected.depth), got.source
        assert got.colour is not None and np.array_equal(got.colour, expected.colour), got.source
    assert got.index == FRAMES - 1


@pytest.mark.parametrize("recording", RUN_FORMATS, indirect=True)
def test_recording_gives_the_folders_trajectory_and_mesh_through_the_cli(
        recording, folder_cli, tmp_path):
    out = _run_cli(recording, tmp_path / "run")
    expected, got = _rows(folder_cli / "trajectory.txt"), _rows(out / "trajectory.txt")
    assert got.shape == expected.shape == (FRAMES, 8)
    assert np.array_equal(got[:, 0], expected[:, 0])
    assert np.abs(got[:, 1:4] - expected[:, 1:4]).max() <= 1e-5  # 0.01 mm
    assert np.abs(got[:, 4:] - expected[:, 4:]).max() <= 1e-6
    assert _mesh_body(out / "mesh.ply") == _mesh_body(folder_cli / "mesh.ply")


@pytest.mark.parametrize("recording", RUN_FORMATS, indirect=True)
def test_recording_gives_the_folders_trajectory_and_mesh_through_python(
        recording, folder_python):
    r = _run_python(recording)
    assert np.array_equal(r.stamps(), folder_python.stamps())
    assert np.abs(r.poses() - folder_python.poses()).max() <= 1e-5
    got, expected = r.mesh(), folder_python.mesh()
    assert expected.colours is not None and len(expected.vertices) > 1000
    assert np.array_equal(got.vertices, expected.vertices)
    assert np.array_equal(got.colours, expected.colours)


@pytest.mark.parametrize("recording", ["ros1"], indirect=True)
def test_topics_can_be_named_after_a_question_mark(recording):
    depth_only = kfx.open(f"{recording}?depth=/camera/depth/image_raw&colour=none")
    assert depth_only.frame_count == FRAMES
    assert next(iter(depth_only)).colour is None
    with pytest.raises(kfx.Error, match="'/camera/nothing'.*image topics: "
                                        "/camera/color/image_raw, /camera/depth/image_raw"):
        kfx.open(f"{recording}?depth=/camera/nothing")
    with pytest.raises(kfx.Error, match="unknown key 'deep'"):
        kfx.open(f"{recording}?deep=/camera/depth/image_raw")
    # The colour topic named as depth: its encoding is no depth encoding.
    with pytest.raises(kfx.Error, match="'/camera/color/image_raw'.*unknown depth encoding "
                                        "'rgb8'"):
        kfx.open(f"{recording}?depth=/camera/color/image_raw")


def test_a_topic_choice_on_a_folder_is_refused():
    if not FOLDER.is_dir():
        pytest.skip(f"{FOLDER} not present")
    with pytest.raises(kfx.Error, match="applies only to recordings"):
        kfx.open(f"{FOLDER}?depth=/camera/depth/image_raw")


@pytest.mark.parametrize("recording", ["ros2"], indirect=True)
def test_bad_ros2_bags_name_the_file_and_the_problem(recording, tmp_path):
    database = next(recording.glob("*.db3"))
    # Truncated: sqlite finds the database malformed.
    truncated = tmp_path / "truncated.db3"
    truncated.write_bytes(database.read_bytes()[: database.stat().st_size // 3])
    with pytest.raises(kfx.Error, match=f"ROS 2 bag '{truncated}'"):
        list(kfx.open(str(truncated)))
    # Stored compressed, or as mcap: named, not misread.
    compressed = tmp_path / "compressed"
    compressed.mkdir()
    (compressed / "compressed.db3").write_bytes(database.read_bytes())
    (compressed / "metadata.yaml").write_text(
        (recording / "metadata.yaml").read_text().replace("compression_format: ''",
                                                          "compression_format: zstd"))
    with pytest.raises(kfx.Error, match="zstd-compressed"):
        kfx.open(str(compressed))
    mcap = tmp_path / "mcap"
    mcap.mkdir()
    (mcap / "mcap_0.mcap").write_bytes(b"\x89MCAP0\r\n")
    with pytest.raises(kfx.Error, match="mcap"):
        kfx.open(str(mcap))


@pytest.mark.parametrize("recording", ["ros1"], indirect=True)
def test_the_cli_refuses_a_truncated_recording_and_writes_nothing(recording, tmp_path):
    cli = kfx_cli()
    if cli is None:
        pytest.skip("the kfx CLI is not built")
    cut = tmp_path / "cut.bag"
    cut.write_bytes(recording.read_bytes()[:100000])
    out = tmp_path / "run"
    result = subprocess.run([str(cli), "run", str(cut), "--backend", "cpu", "-q", "--out",
                             str(out)], capture_output=True, text=True)
    assert result.returncode != 0
    assert f"ROS bag '{cut}'" in result.stderr and "truncated" in result.stderr
    assert not out.exists() or not any(out.iterdir())


@pytest.mark.parametrize("recording", ["ros2"], indirect=True)
def test_a_ros2_database_named_with_uri_characters_opens(recording, tmp_path):
    odd = tmp_path / "take?1#50%.db3"
    odd.write_bytes(next(recording.glob("*.db3")).read_bytes())
    assert kfx.open(str(odd)).frame_count == FRAMES


@pytest.mark.parametrize("form", ["realsense", "realsense-bag"])
def test_realsense_extrinsic_is_read_as_librealsense_recorded_it(form, tmp_path):
    """A recording whose depth-to-colour extrinsic (p_colour = R p_depth + t) librealsense
    itself recorded: kfx run applies it as colour_extrinsic (the depth camera's pose in the
    colour camera's frame: t, then R's rotation vector)."""
    angle = 0.3
    rotation = [[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0], [0, 0, 1]]
    translation = [0.015, -0.002, 0.001]
    path = tmp_path / ("camera.db3" if form == "realsense" else "camera.bag")
    code = ("import sys, kfx.recordings as r; r.write_realsense_bag(sys.argv[1], sys.argv[2], 2, "
            f"depth_to_colour=({rotation}, {translation}))")
    if not FOLDER.is_dir():
        pytest.skip(f"{FOLDER} not present")
    pytest.importorskip("pyrealsense2", reason="pyrealsense2 (pip install kfx[realsense])")
    paths = [p for p in sys.path if p]
    if form == "realsense-bag":
        if not (REALSENSE_BAG_PACKAGE / "pyrealsense2").is_dir():
            pytest.skip(f"the pyrealsense2 that writes .bag files is not at "
                        f"{REALSENSE_BAG_PACKAGE} (scripts/test installs it)")
        paths.insert(0, str(REALSENSE_BAG_PACKAGE))
    subprocess.run([sys.executable, "-c", code, str(FOLDER), str(path)], check=True,
                   capture_output=True, env=dict(os.environ, PYTHONPATH=os.pathsep.join(paths)))
    out = _run_cli(path, tmp_path / "run")
    config = dict(line.split(" = ", 1) for line in (out / "config.txt").read_text().splitlines()
                  if " = " in line)
    extrinsic = [float(v) for v in config["colour_extrinsic"].split(",")]
    assert np.allclose(extrinsic, translation + [0, 0, angle], atol=1e-6), extrinsic
