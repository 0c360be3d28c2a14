"""A live view of a reconstruction in Rerun (``rerun-sdk``, ``pip install kfx[viewer]``): the
camera's pose and path every frame, its depth and colour images at most every
``images_every_s`` (0.1 s), the model as the camera sees it (the last raycast's points and the
shaded render) and, every few seconds, the model's mesh.

The frame loop hands each frame to ``Viewer.submit``, which only keeps references to arrays the
frame already has and never waits: a thread of its own converts and logs them. When that thread
is still busy with an earlier frame, the new one is skipped and counted, so a slow viewer costs
frames in the view, never time in the loop. The model's render, points and mesh need the
reconstruction, which one thread uses at a time: they are taken on the frame loop's thread, at
most every ``model_every_s`` seconds (points and render) and ``mesh_every_s`` seconds (mesh),
and only while that has cost at most ``budget`` (3 %) of the loop's time; the mesh once more at
the end.
"""

from __future__ import annotations

import queue
import threading
import time
from typing import Any, Dict, Optional

import numpy as np


def _rerun() -> Any:
    try:
        import rerun  # noqa: PLC0415 (optional dependency)
    except ImportError as error:
        import kfx  # noqa: PLC0415

        raise kfx.Error("the live view needs the PyPI package 'rerun-sdk' "
                        "(pip install kfx[viewer])") from error
    return rerun


class Viewer:
    """Streams a reconstruction to Rerun: ``sink`` is an ``.rrd`` file to write, ``"spawn"``
    (start a viewer), or ``HOST:PORT`` of a viewer listening for gRPC."""

    def __init__(self, sink: str, images_every_s: float = 0.1, model_every_s: float = 1.0,
                 mesh_every_s: float = 5.0, budget: float = 0.03,
                 application_id: str = "kfx") -> None:
        rr = _rerun()
        self._rr = rr
        self._recording = rr.RecordingStream(application_id)
        if sink == "spawn":
            self._recording.spawn()
        elif sink.endswith(".rrd"):
            self._recording.save(sink)
        else:
            self._recording.connect_grpc(f"rerun+http://{sink}/proxy")
        self.sink = sink
        self.model_every_s = model_every_s
        self.mesh_every_s = mesh_every_s
        self.images_every_s = images_every_s
        self._last_images = -float("inf")
        self.budget = budget
        self._first_submit = 0.0
        self._model_seconds = 0.0
        self._queue: "queue.Queue[Optional[Dict[str, Any]]]" = queue.Queue(maxsize=1)
        self._reconstruction: Any = None
        self.logged = 0
        self.skipped = 0
        self.meshes = 0
        self.submit_seconds = 0.0  # time spent in submit(), on the frame loop's thread
        self._thread = threading.Thread(target=self._log_loop, name="kfx-viewer", daemon=True)
        self._thread.start()

    def submit(self, reconstruction: Any, frame: Any, result: Any) -> None:
        """Hands one processed frame to the view (`frame` has ``depth``, ``colour``, ``stamp``;
        `result` is its FrameResult). Never waits: a busy view skips the frame."""
        started = time.perf_counter()
        self._reconstruction = reconstruction
        if self._queue.full():
            self.skipped += 1
            self.submit_seconds += time.perf_counter() - started
            return
        now = time.monotonic()
        if not self._first_submit:  # the model first after its interval: the map is empty now
            self._first_submit = self._last_model = self._last_mesh = now
        item: Dict[str, Any] = {"index": result.index, "pose": np.asarray(result.pose),
                                "tracked": result.tracked}
        if now - self._last_images >= self.images_every_s:
            self._last_images = now
            item["depth"], item["colour"] = frame.depth, frame.colour
        # The model is taken on this thread: only while that has cost at most `budget` of the
        # time since the first frame (a mesh on the CPU takes seconds; on a GPU milliseconds).
        within_budget = self._model_seconds <= self.budget * (now - self._first_submit)
        if within_budget and now - self._last_model >= self.model_every_s:
            self._last_model = now
            item["points"] = reconstruction.cloud_arrays()
            item["render"] = reconstruction.render()
        if (within_budget and self.mesh_every_s > 0 and
                now - self._last_mesh >= self.mesh_every_s):
            self._last_mesh = now
            item["mesh"] = reconstruction.mesh_arrays()
        self._model_seconds += time.monotonic() - now
        try:
            self._queue.put_nowait(item)
        except queue.Full:
            self.skipped += 1
        self.submit_seconds += time.perf_counter() - started

    def _log_loop(self) -> None:
        while True:
            item = self._queue.get()
            if item is None:
                return
            self._log(item)

    def _log(self, item: Dict[str, Any]) -> None:
        rr, rec = self._rr, self._recording
        rec.set_time("frame", sequence=item["index"])
        pose = item["pose"]
        rec.log("world/camera", rr.Transform3D(translation=pose[:3, 3], mat3x3=pose[:3, :3]))
        rec.log("world/path", rr.Points3D([pose[:3, 3]],
                                          colors=[(0, 200, 0) if item["tracked"] else (220, 0, 0)]))
        if "depth" in item:
            rec.log("camera/depth", rr.DepthImage(item["depth"], meter=1000.0))
            if item["colour"] is not None:
                rec.log("camera/colour", rr.Image(item["colour"]))
        if "render" in item:
            rec.log("camera/model_render", rr.Image(item["render"]))
            points, _, colours = item["points"]
            rec.log("world/model_view", rr.Points3D(points, colors=colours))
        if "mesh" in item:
            self._log_mesh(item["mesh"])
        self.logged += 1

    def _log_mesh(self, mesh: Any) -> None:
        vertices, normals, triangles, colours = mesh
        self._recording.log("world/model", self._rr.Mesh3D(
            vertex_positions=vertices, triangle_indices=triangles, vertex_normals=normals,
            vertex_colors=colours))
        self.meshes += 1

    def close(self) -> Dict[str, Any]:
        """Logs the final mesh, flushes the stream and returns what was logged and skipped."""
        self._queue.put(None)
        self._thread.join()
        if self._reconstruction is not None and self.mesh_every_s >= 0:
            self._log_mesh(self._reconstruction.mesh_arrays())
        self._recording.flush()
        if self.sink.endswith(".rrd"):
            self._recording.disconnect()
        return {"sink": self.sink, "frames_logged": self.logged, "frames_skipped": self.skipped,
                "meshes": self.meshes, "submit_seconds": round(self.submit_seconds, 4)}
