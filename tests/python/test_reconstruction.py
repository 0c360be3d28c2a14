"""kfx from Python: the same trajectory as the CLI byte for byte, numpy in and out, the map."""

import subprocess

import numpy as np
import pytest

import kfx
from conftest import INPUT, SHARED, kfx_cli


def test_trajectory_is_the_cli_runs_byte_for_byte(tmp_path):
    cli = kfx_cli()
    if cli is None:
        pytest.skip("the kfx CLI is not built (build/release/kfx or KFX_CLI)")
    subprocess.run([str(cli), "run", INPUT, "--backend", "cpu", "-q", "--no-mesh", "--no-report",
                    "--set", "volume_resolution=64", "--out", str(tmp_path / "cli")],
                   check=True, capture_output=True)
    sequence = kfx.open(INPUT)
    r = kfx.Reconstruction(sequence, backend="cpu", volume_resolution=64)
    for frame in sequence:
        r.submit(frame)
        if r.frames_in_flight > 1:
            r.collect()
    while r.frames_in_flight:
        r.collect()
    r.save_trajectory(str(tmp_path / "py.txt"))  # names the sequence, as kfx run
    expected = (tmp_path / "cli" / "trajectory.txt").read_bytes()
    assert expected
    assert (tmp_path / "py.txt").read_bytes() == expected


def test_numpy_frames_in_every_layout_give_the_same_poses(frames):
    packed, metres, scaled = (kfx.Reconstruction(kfx.open(INPUT), backend="cpu",
                                                 volume_resolution=64) for _ in range(3))
    for f in frames:
        # The sequence has colour, so these maps fuse it: each frame brings its colour too.
        a = packed.process(np.array(f.depth), stamp=f.stamp, colour=f.colour)
        b = metres.process(f.depth.astype(np.float32) / 1000.0, stamp=f.stamp, colour=f.colour)
        c = scaled.process(f.depth * np.uint16(5), stamp=f.stamp, depth_scale=5000.0,
                           colour=f.colour)
        assert np.array_equal(a.pose, b.pose), f.index
        assert np.array_equal(a.pose, c.pose), f.index
        assert a.stamp == f.stamp
    poses = packed.poses()
    assert poses.shape == (len(frames), 4, 4) and poses.dtype == np.float32
    assert np.array_equal(packed.stamps(), [f.stamp for f in frames])
    # the camera moved and tracking held after the bootstrap frames
    assert not np.array_equal(poses[-1], packed.initial_pose)
    assert all(r.tracked for r in packed.results()[4:])
    assert not any(r.lost for r in packed.results())
    assert not any(r.tracking_ran for r in packed.results()[:4])  # the bootstrap frames


def test_frame_depth_is_a_read_only_view(frames):
    f = frames[3]
    assert f.depth.dtype == np.uint16 and f.depth.shape == (120, 160)
    assert not f.depth.flags.writeable
    # The synthetic room has colour: a read-only (height, width, 3) uint8 view.
    assert f.colour.dtype == np.uint8 and f.colour.shape == (120, 160, 3)
    assert not f.colour.flags.writeable


def test_mesh_cloud_renders_and_map(reconstruction, frames, tmp_path):
    for f in frames:
        result = reconstruction.process(f)
    assert result.pose.shape == (4, 4)
    mesh = reconstruction.mesh()
    assert mesh.vertices.shape[1] == 3 and mesh.vertices.dtype == np.float32
    assert mesh.normals.shape == mesh.vertices.shape
    assert mesh.triangles.shape[1] == 3 and mesh.triangles.dtype == np.int32
    assert len(mesh.triangles) > 100
    assert mesh.triangles.max() < len(mesh.vertices)
    # Colour is fused whenever the input has it (the synthetic room's exact colour).
    assert mesh.colours.shape == mesh.vertices.shape and mesh.colours.dtype == np.uint8
    cloud = reconstruction.point_cloud()
    assert cloud.points.shape[0] > 1000
    assert cloud.colours.shape == cloud.points.shape
    w, h = reconstruction.compute_size
    image = reconstruction.render()
    assert image.shape == (h, w, 4) and image.dtype == np.uint8
    assert (image[..., 0] > 0).mean() > 0.5
    depth = reconstruction.render_depth(reconstruction.pose.astype(np.float64))
    assert depth.shape == (h, w) and (depth > 0).mean() > 0.5

    reconstruction.save_mesh(str(tmp_path / "mesh.ply"), INPUT)
    assert (tmp_path / "mesh.ply").read_bytes().startswith(b"ply\n")
    reconstruction.save_map(str(tmp_path / "map.kfxtsdf"))
    loaded = kfx.Reconstruction(kfx.open(INPUT), backend="cpu", volume_resolution=64)
    loaded.load_map(str(tmp_path / "map.kfxtsdf"))
    again = loaded.mesh()
    assert np.array_equal(again.vertices, mesh.vertices)
    assert np.array_equal(again.triangles, mesh.triangles)


def test_colour(frames, tmp_path):
    """The synthetic scene has colour: fused by default, the mesh and cloud coloured."""
    r = kfx.Reconstruction(kfx.open(INPUT), backend="cpu", volume_resolution=64)
    assert "colour = on" in r.settings_dump()
    for f in frames:
        r.process(f)
    mesh = r.mesh()
    assert mesh.colours.shape == mesh.vertices.shape and mesh.colours.dtype == np.uint8
    assert len(np.unique(mesh.colours, axis=0)) > 10
    assert r.point_cloud().colours.shape[1] == 3
    with pytest.raises(kfx.Error, match="fuses colour .* but the frame has no colour image"):
        r.process(np.array(frames[0].depth))
    # Colour of another size than the depth's is refused before anything runs.
    with pytest.raises(ValueError, match="does not match the depth"):
        r.process(np.array(frames[0].depth), colour=np.zeros((60, 80, 3), np.uint8))
    assert r.frame_count == len(frames)


def test_reset_repeats_the_run(reconstruction, frames):
    first = [reconstruction.process(f).pose for f in frames]
    reconstruction.reset()
    assert reconstruction.frame_count == 0 and len(reconstruction.results()) == 0
    second = [reconstruction.process(f).pose for f in frames]
    assert all(np.array_equal(a, b) for a, b in zip(first, second))


def test_tracking_constraint_per_frame(reconstruction, frames):
    results = [reconstruction.process(f) for f in frames]
    for r in results:
        if not r.tracked:
            continue
        # The synthetic room pins the pose in every direction; the weakest is a unit 6-vector.
        assert r.tracking_constraint > 0.004
        assert len(r.weakest_direction) == 6
        assert abs(sum(v * v for v in r.weakest_direction) - 1.0) < 1e-4
    assert any(r.tracked for r in results)
    assert all(r.tracking_constraint == 0 for r in results if not r.tracking_ran)


def test_camera_and_settings(frames):
    camera = kfx.Camera(160, 120, fx=100.0, fy=100.0, cx=79.5, cy=59.5)
    r = kfx.Reconstruction(camera=camera, backend="cpu", preset="fast",
                           volume_resolution=64, volume_size_m=4.8, init_pose_factor=(0.5, 0.5, 0.1))
    assert "volume_resolution = 64" in r.settings_dump()
    assert r.backend == "cpu"
    assert r.process(frames[0].depth, stamp=1.5).stamp == 1.5
    assert "exact" in kfx.presets()
    keys = [row[0] for row in kfx.settings_table()]
    assert "volume_resolution" in keys and "icp_robust" in keys


def test_online_loop_closure_is_refused_not_ignored():
    """A Reconstruction closes no loops: loop_closure=online is an error naming the setting and
    where loops are closed, not a run without them."""
    camera = kfx.Camera(160, 120, fx=100.0, fy=100.0, cx=79.5, cy=59.5)
    refused = r"setting loop_closure=online: .* does not close loops; online loop closure runs " \
              r"in `kfx run"
    with pytest.raises(kfx.Error, match=refused):
        kfx.Reconstruction(kfx.open(INPUT), backend="cpu", volume_resolution=64,
                           loop_closure="online")
    with pytest.raises(kfx.Error, match=refused):
        kfx.Reconstruction(camera=camera, settings=kfx.make_settings(
            "exact", "cpu", volume_resolution=64, loop_closure="online"))
    assert kfx.Reconstruction(camera=camera, backend="cpu", volume_resolution=64,
                              loop_closure="off").frame_count == 0


def test_several_reconstructions_at_once(frames):
    import threading

    results = {}

    def run(name):
        r = kfx.Reconstruction(kfx.open(INPUT), backend="cpu", volume_resolution=64)
        for f in frames:
            r.process(f)
        results[name] = r.poses()

    threads = [threading.Thread(target=run, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert np.array_equal(results[0], results[1])


def test_every_input_the_cli_reads():
    """Readers of the shared data sets, where present (synthetic: everywhere)."""
    seq = kfx.open("synthetic:frames=3")
    assert [f.index for f in seq] == [0, 1, 2]
    assert seq.camera is not None and seq.ground_truth().shape == (3, 8)
    found = 0
    for name in ["tum_fr1_xyz", "icl_office_kt0", "icl_living_room_kt2_native"]:
        path = SHARED / "data" / name
        if not path.exists():
            continue
        found += 1
        seq = kfx.open(str(path))
        first = next(iter(seq))
        assert first.depth.shape == (seq.height, seq.width)
        assert first.depth.max() > 0
    if found == 0:
        pytest.skip(f"no shared data sets under {SHARED / 'data'}")


def test_open3d_helper(reconstruction, frames):
    for f in frames[:6]:
        reconstruction.process(f)
    mesh = reconstruction.mesh()
    try:
        import open3d  # noqa: F401
    except ImportError:
        with pytest.raises(ImportError, match="needs Open3D"):
            kfx.to_open3d(mesh)
        return
    o3d_mesh = kfx.to_open3d(mesh)
    assert len(o3d_mesh.triangles) == len(mesh.triangles)


def test_warnings_name_the_frame_by_its_number_in_the_input(frames):
    # A wall 7.5 m away (a depth scale off by 5): beyond the volume and implausible.
    camera = kfx.Camera(160, 120, 100.0, 100.0, 79.5, 59.5)
    r = kfx.Reconstruction(camera=camera, backend="cpu", volume_resolution=64)
    near = np.full((120, 160), 1.0, np.float32)
    assert r.process(near).input_index == 0  # none given: the frame's count
    result = r.process(near * 7.5, input_index=41)
    assert (result.index, result.input_index) == (1, 41)
    assert result.warnings and all(w.startswith("frame 41: ") for w in result.warnings)
    with pytest.raises(ValueError, match="input_index"):
        r.process(near, input_index=-2)
    # A Sequence's frames carry their own numbers.
    s = kfx.Reconstruction(kfx.open(INPUT), backend="cpu", volume_resolution=64)
    assert [s.process(f).input_index for f in frames[:3]] == [f.index for f in frames[:3]]


def test_tracking_state_and_the_camera_saved_with_the_map(frames, tmp_path):
    """Each frame says how far its pose can be trusted; a loaded map puts the camera where it
    was saved and integrates nothing before a frame is tracked against it."""
    half = len(frames) // 2
    r = kfx.Reconstruction(kfx.open(INPUT), backend="cpu", volume_resolution=64)
    results = [r.process(f) for f in frames[:half]]
    assert {x.tracking_state for x in results} <= {"good", "poor", "lost"}
    assert results[0].tracking_state == "good"
    r.save_map(str(tmp_path / "map.kfxtsdf"))
    loaded = kfx.Reconstruction(kfx.open(INPUT), backend="cpu", volume_resolution=64)
    assert loaded.load_map(str(tmp_path / "map.kfxtsdf")) == ""  # nothing lacking
    assert np.array_equal(loaded.pose, r.pose)
    first = loaded.process(frames[half])
    assert not first.integrated and first.tracking_state == "lost"  # raycast only
    later = [loaded.process(f) for f in frames[half + 1:]]
    assert later[-1].tracked and later[-1].tracking_state == "good"
    assert all(x.tracked or not x.integrated for x in later)
    with pytest.raises(kfx.Error, match="orthonormal"):
        loaded.set_pose(np.diag([2.0, 1.0, 1.0, 1.0]).astype(np.float32))


def test_localise_one_image_alone_in_a_saved_map(frames, tmp_path):
    """localise(): where in a saved map the camera that saw one image is, from that image alone;
    None when it cannot be told; the run itself is left as it was."""
    r = kfx.Reconstruction(kfx.open(INPUT), backend="cpu", volume_resolution=64,
                           relocalise="on")
    poses = [r.process(f).pose for f in frames]
    r.save_map(str(tmp_path / "map.kfxtsdf"))
    loaded = kfx.Reconstruction(kfx.open(INPUT), backend="cpu", volume_resolution=64,
                                relocalise="on")
    loaded.load_map(str(tmp_path / "map.kfxtsdf"))
    before = loaded.pose
    for i in (20, 6):
        pose = loaded.localise(frames[i])
        assert pose is not None and pose.shape == (4, 4)
        assert np.linalg.norm(pose[:3, 3] - poses[i][:3, 3]) < 0.05
    blank = np.zeros((120, 160), np.float32)
    assert loaded.localise(blank, colour=np.zeros((120, 160, 3), np.uint8)) is None
    assert loaded.results() == [] and np.array_equal(loaded.pose, before)
    plain = kfx.Reconstruction(kfx.open(INPUT), backend="cpu", volume_resolution=64)
    with pytest.raises(kfx.Error, match="relocalise=on"):
        plain.localise(frames[0])
