"""A live view of a reconstruction in Rerun (``rerun-sdk``, ``pip install kfx[viewer]``): the
camera's pose and path (every frame), its depth and colour images (at most every
``images_every_s``, 0.1 s, at half size), the model as the camera sees it (the last raycast's
points, and an image of them shaded by their normals) at most every ``model_every_s`` (1 s), and
the model's mesh every ``mesh_every_s`` (5 s) and at the end.

Everything Rerun does happens in a process of its own, so neither its work nor Python's global
interpreter lock competes with the frame loop, and that process runs at a lower priority, so on
a busy machine the loop's threads come first. The frame loop hands each frame to
``Viewer.submit``, which only keeps references to arrays the frame already has: a sender thread
writes them to the viewer process through a pipe (no copy; the pipe's writes release the
interpreter lock). One view update waits at most; when one is waiting already, the new frame's
images and model are dropped (counted as skipped) and its pose goes with the next update, so the
path is whole and a slow view costs frames in the view, never time in the loop. Downsampling,
shading and Rerun's encoding are all done in the viewer process.

The model's points and mesh need the reconstruction, which one thread uses at a time: they are
taken on the frame loop's thread, only when the view has room for them, at those intervals, and
only while that has cost at most ``budget`` (2 %) of the loop's time since the first frame (a
mesh takes a fraction of a second on the CPU, milliseconds on a GPU).
"""

from __future__ import annotations

import os
import queue
import signal
import subprocess
import sys
import threading
import time
from multiprocessing.connection import Connection
from typing import Any, Dict, List, Optional, Tuple

import numpy as np


def _rerun() -> Any:
    try:
        import rerun  # noqa: PLC0415 (optional dependency)
    except ImportError as error:
        import kfx  # noqa: PLC0415

        raise kfx.Error("the live view needs the PyPI package 'rerun-sdk' "
                        "(pip install kfx[viewer])") from error
    return rerun


def _send(connection: Any, item: Dict[str, Any]) -> None:
    """Writes one view update: its small fields pickled, then each array's bytes as they are."""
    arrays = {k: np.ascontiguousarray(v) for k, v in item.items() if isinstance(v, np.ndarray)}
    small = {k: v for k, v in item.items() if k not in arrays}
    connection.send((small, [(k, a.dtype.str, a.shape) for k, a in arrays.items()]))
    for array in arrays.values():
        connection.send_bytes(array.reshape(-1).view(np.uint8) if array.size else b"")


def _receive(connection: Any) -> Optional[Dict[str, Any]]:
    message = connection.recv()
    if message is None:
        return None
    item, layout = message
    for key, dtype, shape in layout:
        data = connection.recv_bytes()
        item[key] = (np.frombuffer(data, dtype=dtype).reshape(shape) if data
                     else np.zeros(shape, dtype))
    return item


def _shaded(points: np.ndarray, normals: np.ndarray, pose: np.ndarray,
            camera: Tuple[int, int, float, float, float, float]) -> np.ndarray:
    """The raycast's points seen from `pose`, grey by how squarely each faces the camera (the
    model as tracking sees it), (H, W) uint8."""
    width, height, fx, fy, cx, cy = camera
    image = np.zeros((height, width), np.uint8)
    if len(points) == 0:
        return image
    rotation, translation = pose[:3, :3], pose[:3, 3]
    in_camera = (points - translation) @ rotation
    z = in_camera[:, 2]
    seen = z > 1e-6
    u = np.rint(fx * in_camera[seen, 0] / z[seen] + cx).astype(np.int64)
    v = np.rint(fy * in_camera[seen, 1] / z[seen] + cy).astype(np.int64)
    rays = in_camera[seen] / np.linalg.norm(in_camera[seen], axis=1, keepdims=True)
    facing = np.abs(np.einsum("ij,ij->i", normals[seen] @ rotation, rays))
    inside = (u >= 0) & (u < width) & (v >= 0) & (v < height)
    image[v[inside], u[inside]] = (30 + 225 * facing[inside]).astype(np.uint8)
    return image


def _main(argv: List[str]) -> None:
    """The viewer process's entry: its pipes' descriptors, the sink, the application id."""
    receive_fd, answer_fd, sink, application_id, log_delay_s = argv
    # Ctrl-C in a terminal reaches the whole process group: the frame loop's process stops on
    # it and then closes the view, which must still be there to log the last mesh and flush.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _serve(Connection(int(receive_fd), writable=False), Connection(int(answer_fd), readable=False),
           sink, application_id, float(log_delay_s))


def _serve(connection: Any, answers: Any, sink: str, application_id: str,
           log_delay_s: float) -> None:
    """The viewer process: logs each update it receives to Rerun until told to stop, then
    answers with what it logged."""
    try:
        os.nice(10)  # the frame loop's threads first on a busy machine
    except OSError:
        pass
    rr = _rerun()
    recording = rr.RecordingStream(application_id)
    if sink == "spawn":
        recording.spawn()
    elif sink.endswith(".rrd"):
        recording.save(sink)
    else:
        recording.connect_grpc(f"rerun+http://{sink}/proxy")
    counts = {"frames_logged": 0, "poses_logged": 0, "meshes": 0}
    parent_gone = False
    while True:
        try:
            item = _receive(connection)
        except (EOFError, OSError):  # the frame loop's process ended without close()
            parent_gone = True
            break
        if item is None:
            break
        if log_delay_s:
            time.sleep(log_delay_s)  # a view slower than the loop (tests)
        _log(rr, recording, item, counts)
        try:
            answers.send_bytes(b"logged")
        except OSError:
            parent_gone = True
            break
    recording.flush()  # what was logged stays readable, however the loop ended
    if sink.endswith(".rrd"):
        recording.disconnect()
    if not parent_gone:
        answers.send(counts)


def _log(rr: Any, rec: Any, item: Dict[str, Any], counts: Dict[str, int]) -> None:
    for index, tracked, pose in zip(item["indices"], item["tracked"], item["poses"]):
        rec.set_time("frame", sequence=int(index))
        rec.log("world/camera", rr.Transform3D(translation=pose[:3, 3], mat3x3=pose[:3, :3]))
        rec.log("world/path", rr.Points3D([pose[:3, 3]],
                                          colors=[(0, 200, 0) if tracked else (220, 0, 0)]))
        counts["poses_logged"] += 1
    if "mesh_vertices" in item:
        rec.log("world/model", rr.Mesh3D(
            vertex_positions=item["mesh_vertices"], triangle_indices=item["mesh_triangles"],
            vertex_normals=item["mesh_normals"], vertex_colors=item.get("mesh_colours")))
        counts["meshes"] += 1
    if not item.get("view"):
        return
    # The view's images at half size: a quarter of the bytes to encode and store.
    if "depth" in item:
        rec.log("camera/depth", rr.DepthImage(item["depth"][::2, ::2],
                                              meter=item["depth_units_per_m"]))
    if "colour" in item:
        rec.log("camera/colour", rr.Image(item["colour"][::2, ::2]))
    if "points" in item:
        rec.log("world/model_view", rr.Points3D(item["points"], colors=item.get("colours")))
        rec.log("camera/model_render", rr.Image(_shaded(
            item["points"], item["normals"], item["poses"][-1], item["camera"])))
    counts["frames_logged"] += 1


class Viewer:
    """Streams a reconstruction to Rerun: ``sink`` is an ``.rrd`` file to write, ``"spawn"``
    (start a viewer), or ``HOST:PORT`` of a viewer listening for gRPC."""

    def __init__(self, sink: str, images_every_s: float = 0.1, model_every_s: float = 1.0,
                 mesh_every_s: float = 5.0, budget: float = 0.02,
                 application_id: str = "kfx", _log_delay_s: float = 0.0) -> None:
        _rerun()  # says here, not in the viewer process, that rerun-sdk is missing
        self.sink = sink
        self.images_every_s = images_every_s
        self.model_every_s = model_every_s
        self.mesh_every_s = mesh_every_s
        self.budget = budget
        self._last_images = -float("inf")
        self._first_submit = 0.0
        self._model_seconds = 0.0
        self._cloud_cost_s = 0.0  # what the last point cloud and mesh cost the loop
        self._mesh_cost_s = 0.0
        self._reconstruction: Any = None
        self._indices: List[int] = []
        self._tracked: List[bool] = []
        self._poses: List[np.ndarray] = []
        self.skipped = 0  # frames whose images and model were dropped: the view was busy
        self.between = 0  # frames with nothing due but their pose (the intervals above)
        self.submit_seconds = 0.0  # time spent in submit(), on the frame loop's thread
        # A fresh interpreter, started as a command (not a fork of one with the
        # reconstruction's threads in it, nor multiprocessing's spawn, which re-imports the
        # user's main script); the two ends of a pair of pipes are its connection.
        to_viewer, from_us = os.pipe()
        to_us, from_viewer = os.pipe()
        try:
            import fcntl  # noqa: PLC0415 (Linux: room for an image per write, fewer wake-ups)

            fcntl.fcntl(from_us, getattr(fcntl, "F_SETPIPE_SZ", 1031), 1 << 20)
        except (ImportError, OSError):
            pass
        self._process = subprocess.Popen(
            [sys.executable, "-c", "import sys, kfx.viewer as v; v._main(sys.argv[1:])",
             str(to_viewer), str(from_viewer), sink, application_id, repr(_log_delay_s)],
            pass_fds=(to_viewer, from_viewer), close_fds=True)
        os.close(to_viewer)
        os.close(from_viewer)
        self._connection = Connection(from_us, readable=False)
        self._answers = Connection(to_us, writable=False)
        self._queue: "queue.Queue[Optional[Dict[str, Any]]]" = queue.Queue(maxsize=1)
        self._sender_error: Optional[BaseException] = None
        self._handed = 0  # updates put in the queue (by the frame loop's thread only)
        self._done = 0  # updates the sender finished with (by the sender thread only)
        self._thread = threading.Thread(target=self._send_loop, name="kfx-viewer-send",
                                        daemon=True)
        self._thread.start()

    def _send_loop(self) -> None:
        try:
            os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), 10)
        except (AttributeError, OSError):
            pass
        while True:
            item = self._queue.get()
            if item is None:
                return
            try:
                _send(self._connection, item)
                # One update at a time: the next waits until this one is logged, so what waits
                # is this thread's one queued update, never a pipe full of stale images.
                self._answers.recv_bytes()
            except (OSError, EOFError, ValueError) as error:  # the viewer process is gone
                self._sender_error = error
                return
            finally:
                self._done += 1

    def submit(self, reconstruction: Any, frame: Any, result: Any) -> None:
        """Hands one processed frame to the view (`frame` has ``depth``, ``colour``; `result` is
        its FrameResult). Never waits: when an update is waiting already, this frame's images
        and model are dropped (its pose goes with the next update)."""
        started = time.perf_counter()
        self._reconstruction = reconstruction
        self._indices.append(result.index)
        self._tracked.append(bool(result.tracked))
        self._poses.append(np.asarray(result.pose, np.float32))
        if self._queue.full() or self._sender_error is not None:
            self.skipped += 1
            self.submit_seconds += time.perf_counter() - started
            return
        now = time.monotonic()
        if not self._first_submit:  # the model first after its interval: the map is empty now
            self._first_submit = self._last_model = self._last_mesh = now
        item: Dict[str, Any] = {"indices": self._indices, "tracked": self._tracked,
                                "poses": np.stack(self._poses), "view": False}
        self._indices, self._tracked, self._poses = [], [], []
        if now - self._last_images >= self.images_every_s:
            self._last_images = now
            item["view"] = True
            if frame.depth is not None:
                item["depth"] = frame.depth
                item["depth_units_per_m"] = float(getattr(frame, "depth_units_per_m", 1000.0))
            if frame.colour is not None:
                item["colour"] = frame.colour
        # Each extraction only if, at what the last one of its kind cost, the model stays within
        # `budget` of the loop's time since the first frame.
        allowed = self.budget * (now - self._first_submit) - self._model_seconds
        if self._cloud_cost_s <= allowed and now - self._last_model >= self.model_every_s:
            self._last_model = now
            item["view"] = True
            points, normals, colours = reconstruction.cloud_arrays()
            item["points"], item["normals"] = points, normals
            if colours is not None:
                item["colours"] = colours
            camera, (width, height) = reconstruction.camera, reconstruction.compute_size
            sx, sy = width / camera.width, height / camera.height
            item["camera"] = (width, height, camera.fx * sx, camera.fy * sy,
                              (camera.cx + 0.5) * sx - 0.5, (camera.cy + 0.5) * sy - 0.5)
            self._cloud_cost_s = time.monotonic() - now
            allowed -= self._cloud_cost_s
        if (self._mesh_cost_s <= allowed and self.mesh_every_s > 0 and
                now - self._last_mesh >= self.mesh_every_s):
            self._last_mesh = now
            mesh_started = time.monotonic()
            self._add_mesh(item, reconstruction.mesh_arrays())
            self._mesh_cost_s = time.monotonic() - mesh_started
        self._model_seconds += time.monotonic() - now
        if not item["view"]:
            self.between += 1  # no image or model due: only its pose
        self._queue.put_nowait(item)  # room: checked above, and only this thread puts
        self._handed += 1
        self.submit_seconds += time.perf_counter() - started

    def flush(self) -> None:
        """Waits until every update handed over so far is logged (not for the frame loop: a
        view that must show every frame, a snapshot, a test)."""
        while self._done < self._handed and self._thread.is_alive():
            time.sleep(0.005)

    @staticmethod
    def _add_mesh(item: Dict[str, Any], mesh: Any) -> None:
        vertices, normals, triangles, colours = mesh
        item.update(mesh_vertices=vertices, mesh_normals=normals, mesh_triangles=triangles)
        if colours is not None:
            item["mesh_colours"] = colours

    def close(self) -> Dict[str, Any]:
        """Sends the last poses and the final mesh, waits for the viewer process to log them and
        flush, and returns what was logged and skipped."""
        final: Dict[str, Any] = {"indices": self._indices, "tracked": self._tracked,
                                 "poses": (np.stack(self._poses) if self._poses
                                           else np.zeros((0, 4, 4), np.float32)),
                                 "view": False}
        if self._reconstruction is not None and self.mesh_every_s >= 0:
            self._add_mesh(final, self._reconstruction.mesh_arrays())
        while self._thread.is_alive():  # room for the last update, unless the sender stopped
            try:
                self._queue.put(final, timeout=0.1)
                break
            except queue.Full:
                continue
        while self._thread.is_alive():
            try:
                self._queue.put(None, timeout=0.1)
                break
            except queue.Full:
                continue
        self._thread.join()
        counts: Dict[str, Any] = {}
        try:
            if self._sender_error is None:
                self._connection.send(None)
                counts = self._answers.recv()
        except (OSError, EOFError):
            pass
        self._connection.close()
        self._answers.close()
        try:
            self._process.wait(timeout=60)
        except subprocess.TimeoutExpired:
            self._process.kill()
            self._process.wait()
        if not counts:
            import kfx  # noqa: PLC0415

            raise kfx.Error(f"the live view's process stopped early (exit code "
                            f"{self._process.returncode}); the view in '{self.sink}' may be "
                            "incomplete")
        return {"sink": self.sink, "frames_logged": counts["frames_logged"],
                "frames_skipped": self.skipped, "frames_between": self.between,
                "poses_logged": counts["poses_logged"],
                "meshes": counts["meshes"], "submit_seconds": round(self.submit_seconds, 4)}
