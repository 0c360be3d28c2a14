"""The Python front end speaks Python: a camera overrides a sequence's intrinsics, errors give
keyword arguments rather than command-line flags, a Sequence iterates again from the start, and
meshes and clouds print as summaries."""

import copy
import re

import pytest

import kfx

from conftest import INPUT


def test_camera_overrides_the_sequences_intrinsics():
    sequence = kfx.open(INPUT)
    assert sequence.camera.fx != 100.0
    camera = kfx.Camera(160, 120, fx=100.0, fy=101.0, cx=79.0, cy=60.0)
    settings = kfx.make_settings("exact", "cpu", volume_resolution=64)
    r = kfx.Reconstruction(sequence, camera=camera, settings=settings)
    used = r.camera
    assert (used.fx, used.fy, used.cx, used.cy) == (100.0, 101.0, 79.0, 60.0)
    assert "camera = 100,101,79,60" in r.settings_dump()
    # The user's Settings are left as they were.
    assert "camera" not in dict(settings.overrides)
    for frame in sequence:
        assert r.process(frame).index == 0
        break
    # A camera of another size than the frames is refused, naming both.
    with pytest.raises(kfx.Error, match=r"camera= is 320x240 px but the frames of .* are 160x120"):
        kfx.Reconstruction(kfx.open(INPUT), camera=kfx.Camera(320, 240, 200.0, 200.0, 160.0, 120.0),
                           backend="cpu", volume_resolution=64)


def test_settings_copy_is_independent():
    settings = kfx.make_settings("exact", "cpu")
    other = copy.copy(settings)
    other.set("volume_resolution", "64")
    assert "volume_resolution" not in dict(settings.overrides)


def test_errors_give_python_names_not_command_line_flags():
    # Every phrase the library uses for the command line has a Python wording.
    for cli, python in [("give -k fx,fy,cx,cy if these are wrong", "give camera=kfx.Camera(...)"),
                        ("give them with -k fx,fy,cx,cy (pixels)", "with camera=kfx.Camera(...)"),
                        ("no GPU; use --backend cpu", 'use backend="cpu"'),
                        ("a larger voxel_size_m or --backend cpu", 'or backend="cpu"'),
                        ("(use --no-mesh or a smaller -v)", "use a smaller volume_resolution"),
                        ("a smaller volume resolution (-v / volume_resolution)", "(volume_resolution)"),
                        ("is --depth-scale right? (TUM)", "is depth_scale right?")]:
        text = kfx._kfx._python_advice(cli)
        assert python in text, (cli, text)
        assert not re.search(r"(^|\s|\()--?[a-z]", text), text
    # A real error: the CUDA backend where there is none.
    ok, why = kfx.has_cuda()
    if ok:
        pytest.skip("a GPU is present: the CUDA backend's error cannot be raised here")
    with pytest.raises(kfx.Error) as error:
        kfx.Reconstruction(kfx.open(INPUT), backend="cuda", volume_resolution=64)
    assert "--backend" not in str(error.value), str(error.value)


def test_sequence_iterates_again_from_the_start():
    sequence = kfx.open("synthetic:frames=5,width=160,height=120")
    first = [(f.index, f.stamp) for f in sequence]
    second = [(f.index, f.stamp) for f in sequence]
    assert len(first) == 5
    assert second == first
    # A loop left early starts over too.
    for frame in sequence:
        break
    assert [f.index for f in sequence] == [0, 1, 2, 3, 4]


def test_mesh_and_cloud_reprs_summarise(reconstruction):
    for frame in kfx.open(INPUT):
        reconstruction.process(frame)
    mesh, cloud = reconstruction.mesh(), reconstruction.point_cloud()
    assert len(mesh.vertices) > 1000
    text = repr(mesh)
    assert re.fullmatch(rf"Mesh\({len(mesh.vertices)} vertices, {len(mesh.triangles)} triangles, "
                        r"(no )?colours, bounds x .* m\)", text), text
    assert len(text) < 200
    text = repr(cloud)
    assert text.startswith(f"PointCloud({len(cloud.points)} points, ") and len(text) < 200, text
