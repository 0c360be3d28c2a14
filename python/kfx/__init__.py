"""kfx: KinectFusion (dense RGB-D SLAM) for CPUs and NVIDIA GPUs.

    import kfx
    sequence = kfx.open("synthetic:frames=60")
    reconstruction = kfx.Reconstruction(sequence, preset="exact", backend="cpu")
    for frame in sequence:
        result = reconstruction.process(frame)      # result.pose: 4x4, result.tracked
    reconstruction.save_mesh("mesh.ply")

Settings are keyword arguments checked by the one settings table (``kfx.settings_table()``,
``kfx settings`` on the command line); every error is a ``kfx.Error`` naming the problem.

The tools above the library are imported on their own: ``kfx.study`` (sweep results, the
search, the ATE breakdown, the soak benchmark) and ``kfx.plots`` (figures; matplotlib).
"""

from __future__ import annotations

import copy
import warnings
from dataclasses import dataclass
from typing import Any, Iterator, Optional

from ._kfx import (
    Camera,
    Error,
    Frame,
    FrameResult,
    ReadStatus,
    Settings,
    has_cuda,
    has_openni2,
    presets,
    settings_table,
    version,
)
from ._kfx import Sequence as _Sequence
from ._kfx import _Reconstruction

__all__ = [
    "Camera", "Error", "Frame", "FrameResult", "Mesh", "PointCloud", "Reconstruction",
    "Sequence", "Settings", "has_cuda", "has_openni2", "make_settings", "open", "presets",
    "settings_table", "to_open3d", "version",
]
__version__ = version()


def _setting_text(key: str, value: Any) -> str:
    """A keyword argument's value as the settings table reads it."""
    if isinstance(value, bool):
        return "on" if value else "off"
    if isinstance(value, (list, tuple)):
        return ",".join(_setting_text(key, v) for v in value)
    if isinstance(value, (int, float, str)):
        return str(value)
    # numpy scalars and arrays
    if hasattr(value, "tolist"):
        return _setting_text(key, value.tolist())
    raise Error(f"setting '{key}': cannot use a value of type {type(value).__name__}")


def make_settings(preset: str = "exact", backend: str = "auto", cuda_device: int = -1,
                  **settings: Any) -> Settings:
    """A Settings from a preset, the backend and settings as keyword arguments
    (``volume_resolution=128``, ``camera=(fx, fy, cx, cy)``, ``icp_robust="huber"``)."""
    s = Settings(preset)
    s.backend = backend
    s.cuda_device = cuda_device
    for key, value in settings.items():
        s.set(key, _setting_text(key, value))
    return s


class Sequence(_Sequence):
    """Frames of an input, read in order: a TUM RGB-D or ICL-NUIM folder, ICL-NUIM's native
    form, a SLAMBench ``.raw``, a recording (a RealSense ``.bag``/``.db3``, a ROS 1 bag or a
    ROS 2 bag; ``INPUT?depth=/topic&colour=/topic`` names its topics where they are ambiguous,
    docs/cameras.md) or ``synthetic[:scene=room|house|twins,frames=N,width=W,height=H,...]``.

    Iterating yields ``kfx.Frame`` objects (``.depth`` in millimetres, ``.stamp``). A bad frame
    raises ``kfx.Error`` naming it, or with ``skip_bad_frames=True`` is skipped with a warning.
    Each ``for`` loop starts again from the first frame (the input is opened again).
    """

    def __init__(self, input: str, depth_scale: float = 0.0, ground_truth: str = "",
                 skip_bad_frames: bool = False) -> None:
        super().__init__(input, depth_scale, ground_truth)
        self.skip_bad_frames = skip_bad_frames
        self.skipped = 0
        self._opened_with = (depth_scale, ground_truth)
        self._started = False  # a frame was read since the input was opened

    def __iter__(self) -> Iterator[Frame]:
        if self._started:
            self._reopen(*self._opened_with)
            self.skipped = 0
            self._started = False
        return self

    def __next__(self) -> Frame:
        while True:
            status, frame = self.read()
            self._started = True
            if status == ReadStatus.OK:
                return frame
            if status == ReadStatus.END:
                raise StopIteration
            if not self.skip_bad_frames:
                raise Error(self.message + " (skip_bad_frames=True skips bad frames)")
            warnings.warn("kfx: skipping bad frame: " + self.message, stacklevel=2)
            self.skipped += 1


def open(input: str, depth_scale: float = 0.0, ground_truth: str = "",
         skip_bad_frames: bool = False) -> Sequence:
    """Opens an input as a Sequence (see ``kfx.Sequence``)."""
    return Sequence(input, depth_scale, ground_truth, skip_bad_frames)


def _bounds_text(points: Any) -> str:
    """The axis-aligned bounds of (N, 3) points, for a repr."""
    if len(points) == 0:
        return "empty"
    low, high = points.min(axis=0), points.max(axis=0)
    return "bounds " + " ".join(f"{a} {lo:.2f}..{hi:.2f} m" for a, lo, hi in zip("xyz", low, high))


@dataclass(repr=False)
class Mesh:
    """A triangle mesh in the map frame (metres)."""

    vertices: Any  #: (N, 3) float32
    normals: Any  #: (N, 3) float32, unit
    triangles: Any  #: (M, 3) int32, counter-clockwise seen from free space
    colours: Any = None  #: (N, 3) uint8, or None when the map holds no colour

    def __repr__(self) -> str:  # a summary: the arrays can hold millions of rows
        return (f"Mesh({len(self.vertices)} vertices, {len(self.triangles)} triangles, "
                f"{'colours' if self.colours is not None else 'no colours'}, "
                f"{_bounds_text(self.vertices)})")


@dataclass(repr=False)
class PointCloud:
    """Points with normals in the map frame (metres), as the last raycast saw the surface."""

    points: Any  #: (N, 3) float32
    normals: Any  #: (N, 3) float32
    colours: Any = None  #: (N, 3) uint8 or None

    def __repr__(self) -> str:
        return (f"PointCloud({len(self.points)} points, "
                f"{'colours' if self.colours is not None else 'no colours'}, "
                f"{_bounds_text(self.points)})")


class Reconstruction(_Reconstruction):
    """A KinectFusion reconstruction: frames in, one at a time; the pose after each; the map
    on demand.

    ``Reconstruction(sequence, preset="exact", backend="auto", **settings)`` sets it up for a
    Sequence's frames (its camera and recommended settings, as ``kfx run``);
    ``Reconstruction(camera=kfx.Camera(...), **settings)`` for frames you bring as numpy arrays;
    with both, the camera's intrinsics (and lens) replace the sequence's.
    One reconstruction is used from one thread at a time; several may run side by side.
    It closes no loops: ``loop_closure="online"`` raises kfx.Error (online loop closure runs in
    ``kfx run``, and ``kfx optimise`` closes a finished run's loops: docs/loop_closure.md).
    """

    def __init__(self, sequence: Optional[_Sequence] = None, *, camera: Optional[Camera] = None,
                 preset: str = "exact", backend: str = "auto", cuda_device: int = -1,
                 settings: Optional[Settings] = None, **kwargs: Any) -> None:
        if settings is None:
            settings = make_settings(preset, backend, cuda_device, **kwargs)
        elif kwargs:
            raise Error("give settings either as a kfx.Settings or as keyword arguments")
        if sequence is None and camera is None:
            raise Error("give a sequence, a camera (camera=kfx.Camera(...)), or both (the camera "
                        "then replaces the sequence's intrinsics)")
        if sequence is not None and camera is not None:
            if (camera.width, camera.height) != (sequence.width, sequence.height):
                raise Error(f"camera= is {camera.width}x{camera.height} px but the frames of "
                            f"{sequence.input} are {sequence.width}x{sequence.height}")
            # As the settings camera= and camera_distortion= would (the user's Settings stay
            # as they were).
            settings = copy.copy(settings)
            settings.set("camera", _setting_text("camera", (camera.fx, camera.fy, camera.cx,
                                                            camera.cy)))
            if any(camera.distortion):
                settings.set("camera_distortion",
                             _setting_text("camera_distortion", list(camera.distortion)))
        if sequence is not None:
            super().__init__(settings, sequence)
        else:
            super().__init__(settings, camera)

    def process(self, frame: Any, stamp: float = 0.0, depth_scale: Optional[float] = None,
                colour: Any = None, input_index: Optional[int] = None) -> FrameResult:
        """Processes the next frame: a ``kfx.Frame`` from a Sequence, or a depth array (uint16
        in units of ``1/depth_scale`` m, millimetres by default; or float32 metres), its
        ``stamp``, optionally a uint8 (H, W, 3) colour image and the frame's number in its
        input (``input_index``: named in warnings, returned as ``FrameResult.input_index``; a
        Sequence's frames carry theirs). Returns its FrameResult."""
        if isinstance(frame, Frame):
            return self.process_frame(frame)
        return self.process_array(frame, stamp, depth_scale, colour, input_index)

    def submit(self, frame: Any, stamp: float = 0.0, depth_scale: Optional[float] = None,
               colour: Any = None, input_index: Optional[int] = None) -> None:
        """As process(), without waiting: collect() returns the result (on the GPU the frame
        computes while Python prepares the next)."""
        if isinstance(frame, Frame):
            self.submit_frame(frame)
        else:
            self.submit_array(frame, stamp, depth_scale, colour, input_index)

    def integrate_at(self, frame: Any, pose: Any, colour: Any = None, stamp: float = 0.0,
                     depth_scale: Optional[float] = None,
                     input_index: Optional[int] = None) -> FrameResult:
        """Integrates the next frame at ``pose`` (4x4 float32 or float64, camera to map frame,
        metres) instead of tracking it: the map becomes the fusion of the frames at the poses
        given (a trajectory optimised after the run, ground truth). ``frame`` and the other
        arguments as in process(); the frames in flight are collected first. Raises kfx.Error
        naming the frame when the pose is not a rigid transform. Returns its FrameResult, whose
        pose is the one given."""
        if isinstance(frame, Frame):
            if colour is not None:
                raise Error("a kfx.Frame brings its own colour image: give colour= with a "
                            "depth array only")
            return self.integrate_frame_at(frame, pose)
        return self.integrate_array_at(frame, pose, stamp, depth_scale, colour, input_index)

    def localise(self, frame: Any, colour: Any = None,
                 depth_scale: Optional[float] = None) -> Optional[Any]:
        """Where in the map is the camera that saw ``frame`` (a kfx.Frame or a depth array, as in
        process())? Answered from this image alone, with no use of the current pose: its
        nearest keyframes (setting relocalise; loaded with the map or harvested so far) are
        tried, each verified by tracking the image against the map seen from there. Returns the
        pose (4x4 float32, camera to map frame) or None when the image cannot be located.
        Integrates nothing, adds nothing to results(), leaves the camera where it was."""
        if isinstance(frame, Frame):
            if colour is not None:
                raise Error("a kfx.Frame brings its own colour image: give colour= with a "
                            "depth array only")
            return self.localise_frame(frame)
        return self.localise_array(frame, depth_scale, colour)

    def mesh(self) -> Mesh:
        """The map as a triangle mesh (marching cubes)."""
        return Mesh(*self.mesh_arrays())

    def point_cloud(self) -> PointCloud:
        """The surface as the last raycast saw it."""
        return PointCloud(*self.cloud_arrays())


def to_open3d(mesh: Mesh) -> Any:
    """The mesh as an ``open3d.geometry.TriangleMesh`` (needs Open3D installed)."""
    try:
        import open3d  # noqa: PLC0415 (optional dependency)
    except ImportError as e:
        raise ImportError("kfx.to_open3d needs Open3D: pip install open3d") from e
    import numpy as np  # noqa: PLC0415

    o3d_mesh = open3d.geometry.TriangleMesh(
        open3d.utility.Vector3dVector(np.asarray(mesh.vertices, dtype=np.float64)),
        open3d.utility.Vector3iVector(np.asarray(mesh.triangles, dtype=np.int32)))
    o3d_mesh.vertex_normals = open3d.utility.Vector3dVector(
        np.asarray(mesh.normals, dtype=np.float64))
    if mesh.colours is not None:
        o3d_mesh.vertex_colors = open3d.utility.Vector3dVector(
            np.asarray(mesh.colours, dtype=np.float64) / 255.0)
    return o3d_mesh
