"""Live reconstruction from a RealSense camera (``pyrealsense2``, ``pip install kfx[realsense]``)
or an OpenNI2 device (the library's ``openni2:`` input: Kinect v1, Xtion, Orbbec; kfx built with
OpenNI2), or from a recording played back at the camera's pace standing in for one (a RealSense
recording, or an OpenNI2 ``.oni`` that OpenNI2 plays as a device).

The camera is read on a thread of its own into a bounded queue: when the reconstruction falls
behind, the oldest waiting frame is dropped and counted, so the queue never grows and the frame
processed is always a recent one. Ctrl-C (SIGINT) or SIGTERM stops the camera and writes every
output of the frames processed: ``trajectory.txt``, ``mesh.ply`` and ``stats.json`` (frames
received, processed and dropped, and the deepest the queue got).

``kfx live --out DIR [--from-file REC | --openni [URI]] [--set key=value]...`` runs this module
(``python -m kfx.live``); ``kfx.live.run(...)`` is the same from Python.
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import queue
import signal
import sys
import threading
import time
from dataclasses import asdict, dataclass, field
from typing import Any, Callable, Dict, List, Optional

import numpy as np

import kfx


def _realsense() -> Any:
    try:
        import pyrealsense2  # noqa: PLC0415 (optional dependency)
    except ImportError as error:
        openni = ("kfx live --openni [URI] (kfx.live.run(..., openni=URI)) reads one instead"
                  if kfx.has_openni2() else
                  "this kfx was built without OpenNI2 either (Debian's libopenni2-dev), which "
                  "would read an OpenNI2 device instead")
        raise kfx.Error("a RealSense camera needs the PyPI package 'pyrealsense2' "
                        "(pip install kfx[realsense]); it is not "
                        f"installed for {sys.executable}. For an OpenNI2 device (Kinect v1, "
                        f"Xtion, Orbbec), {openni}") from error
    return pyrealsense2


@dataclass
class LiveFrame:
    """One camera frame as the reconstruction takes it."""
    depth: np.ndarray            # uint16 (H, W), in units of 1/depth_scale metres
    colour: Optional[np.ndarray]  # uint8 (H, W, 3) RGB registered to the depth, or None
    stamp: float                 # the camera's timestamp, seconds
    number: int                  # the camera's frame number
    depth_units_per_m: float = 1000.0  # what `depth` counts in a metre


@dataclass
class LiveStats:
    """What a live run counts; written as stats.json."""
    source: str = ""
    frames_received: int = 0     # frames the camera delivered to kfx
    frames_processed: int = 0    # frames the reconstruction ran on
    frames_dropped: int = 0      # received, not processed: dropped from the full queue (kfx
    #                              fell behind) or still waiting when stopped
    frames_missed: int = 0       # gaps in the camera's frame numbers (lost before kfx saw them)
    frames_bad: int = 0          # frames the camera delivered that could not be read (skipped)
    queue_size: int = 0          # the queue's bound
    max_queue_depth: int = 0     # the most frames that ever waited
    seconds: float = 0.0         # from the first frame received to the stop
    processed_per_s: float = 0.0
    stopped_by: str = ""         # "end of recording", "frame limit", "signal SIGINT", ...
    viewer: Dict[str, Any] = field(default_factory=dict)


class _LiveSource:
    """What every live source shares: its frames read on a thread of its own into a bounded
    queue (the oldest dropped and counted when full), the counts, and a clean stop. A source
    sets ``source``, ``camera`` (a kfx.Camera), ``depth_units_m`` and ``has_colour``, then calls
    ``_start``; it reads a frame in ``_read`` and lets its device go in ``_close``."""

    end_reason = ""  # why the camera stopped on its own ("end of recording")
    error: Optional[BaseException] = None  # what stopped the capture thread, if it failed
    source = ""
    camera: Any = None
    depth_units_m = 0.001

    @property
    def has_colour(self) -> bool:
        """Whether the camera delivers colour registered to its depth."""
        return False

    def _start(self, queue_size: int, wait_when_full: bool) -> None:
        """Starts the reading thread. `wait_when_full`: a recording read as fast as it is read
        waits for room in the queue instead of dropping (reading it loses nothing)."""
        self.queue: "queue.Queue[Optional[LiveFrame]]" = queue.Queue(maxsize=queue_size)
        self.stats = LiveStats(source=self.source, queue_size=queue_size)
        self._stop = threading.Event()
        self._wait_when_full = wait_when_full
        self._last_number: Optional[int] = None
        self._lock = threading.Lock()
        self._thread = threading.Thread(target=self._capture, name="kfx-camera", daemon=True)
        self._thread.start()

    def _read(self) -> Optional[LiveFrame]:
        """The next frame, or None when none came in a short while (the stop is looked at
        between reads); raises StopIteration, with end_reason set, when the camera has ended."""
        raise NotImplementedError

    def _close(self) -> None:
        """Lets the device go (after the reading thread ended)."""

    def _put(self, frame: Optional[LiveFrame], wait: bool) -> None:
        """Queues `frame`. When the queue is full, `wait` waits for room while the camera runs
        (a recording played as fast as it is read: reading it loses nothing); otherwise the
        oldest waiting frame is dropped and counted."""
        while wait and not self._stop.is_set():
            try:
                self.queue.put(frame, timeout=0.1)
                break
            except queue.Full:
                pass
        else:
            while True:
                try:
                    self.queue.put_nowait(frame)
                    break
                except queue.Full:
                    try:
                        dropped = self.queue.get_nowait()
                    except queue.Empty:
                        continue
                    if dropped is not None:
                        with self._lock:
                            self.stats.frames_dropped += 1
        with self._lock:
            self.stats.max_queue_depth = max(self.stats.max_queue_depth, self.queue.qsize())

    def _capture(self) -> None:
        try:
            while not self._stop.is_set():
                try:
                    frame = self._read()
                except StopIteration:
                    break
                if frame is None:
                    continue
                with self._lock:
                    if self._last_number is not None and frame.number > self._last_number + 1:
                        self.stats.frames_missed += frame.number - self._last_number - 1
                    self._last_number = frame.number
                    self.stats.frames_received += 1
                self._put(frame, self._wait_when_full)
        except Exception as error:  # noqa: BLE001 (reported by the reading side)
            self.error = error
        finally:
            # Tells the reader the camera stopped, where there is room: a full queue's frames
            # are still to be processed (the reader sees the end once it has taken them).
            try:
                self.queue.put_nowait(None)
            except queue.Full:
                pass

    @property
    def running(self) -> bool:
        """False once the camera stopped (ended, failed or was stopped) and sends no more."""
        return self._thread.is_alive()

    def stop(self) -> None:
        self._stop.set()
        self._thread.join()
        self._close()


class Camera(_LiveSource):
    """A RealSense device, or a recording played at the camera's pace, yielding LiveFrames on
    a thread into a bounded queue (oldest dropped when full)."""

    def __init__(self, from_file: str = "", serial: str = "", width: int = 640,
                 height: int = 480, fps: int = 30, colour: bool = True, queue_size: int = 2,
                 real_time: bool = True) -> None:
        rs = _realsense()
        self._rs = rs
        config = rs.config()
        if from_file:
            if not os.path.isfile(from_file):
                raise kfx.Error(f"recording '{from_file}' does not exist")
            config.enable_device_from_file(from_file, repeat_playback=False)
        else:
            if serial:
                config.enable_device(serial)
            config.enable_stream(rs.stream.depth, width, height, rs.format.z16, fps)
            if colour:
                config.enable_stream(rs.stream.color, width, height, rs.format.rgb8, fps)
        self._pipeline = rs.pipeline()
        try:
            profile = self._pipeline.start(config)
        except RuntimeError as error:
            where = f"recording '{from_file}'" if from_file else "a RealSense camera"
            raise kfx.Error(f"cannot start {where}: {error}") from error
        device = profile.get_device()
        self._playback = device.as_playback() if from_file else None
        if self._playback is not None:
            self._playback.set_real_time(real_time)
        self.source = from_file or (device.get_info(rs.camera_info.name) + " " +
                                    device.get_info(rs.camera_info.serial_number))
        depth_profile = profile.get_stream(rs.stream.depth).as_video_stream_profile()
        k = depth_profile.get_intrinsics()
        coeffs = list(k.coeffs)[:5] if k.model in (rs.distortion.brown_conrady,) else [0.0] * 5
        self.camera = kfx.Camera(k.width, k.height, k.fx, k.fy, k.ppx, k.ppy, coeffs)
        self.depth_units_m = device.first_depth_sensor().get_depth_scale()
        streams = {s.stream_type(): s for s in profile.get_streams()}
        self._colour = colour and rs.stream.color in streams
        # Colour is aligned to the depth camera, unless it is that camera already (a registered
        # recording): rs.align costs milliseconds a frame.
        self._align = None
        if self._colour:
            colour_profile = streams[rs.stream.color].as_video_stream_profile()
            c = colour_profile.get_intrinsics()
            extrinsic = depth_profile.get_extrinsics_to(colour_profile)
            registered = ((c.width, c.height, c.fx, c.fy, c.ppx, c.ppy) ==
                          (k.width, k.height, k.fx, k.fy, k.ppx, k.ppy) and
                          np.allclose(extrinsic.rotation, np.eye(3).reshape(9)) and
                          np.allclose(extrinsic.translation, 0))
            if not registered:
                self._align = rs.align(rs.stream.depth)
        self._start(queue_size, wait_when_full=bool(from_file) and not real_time)

    @property
    def has_colour(self) -> bool:
        """Whether the camera delivers colour registered to its depth."""
        return bool(self._colour)

    def _frame(self, frames: Any) -> Optional[LiveFrame]:
        if self._align is not None:
            frames = self._align.process(frames)
        depth = frames.get_depth_frame()
        if not depth:
            return None
        colour_frame = frames.get_color_frame() if self._colour else None
        colour = None
        if colour_frame:
            colour = np.array(colour_frame.get_data(), copy=True)
            if colour_frame.get_profile().format() == self._rs.format.bgr8:
                colour = np.ascontiguousarray(colour[..., ::-1])
        return LiveFrame(np.array(depth.get_data(), copy=True), colour,
                         depth.get_timestamp() * 1e-3, depth.get_frame_number(),
                         1.0 / self.depth_units_m)

    def _read(self) -> Optional[LiveFrame]:
        ok, frames = self._pipeline.try_wait_for_frames(200)
        if not ok:
            if (self._playback is not None and self._playback.current_status()
                    == self._rs.playback_status.stopped):
                self.end_reason = "end of recording"
                raise StopIteration
            return None
        return self._frame(frames)

    def _close(self) -> None:
        try:
            self._pipeline.stop()
        except RuntimeError:
            pass


class OpenNI2Camera(_LiveSource):
    """An OpenNI2 device (the first one OpenNI2 finds, or the one at ``uri``), or an ``.oni``
    recording OpenNI2 plays as a device at its recorded pace, read through the library's
    ``openni2:`` input on a thread into a bounded queue (oldest dropped when full). Depth comes
    in millimetres, the intrinsics from the device's field of view (docs/cameras.md)."""

    def __init__(self, uri: str = "", colour: bool = True, queue_size: int = 2,
                 real_time: bool = True) -> None:
        options = ([] if real_time else ["real_time=off"]) + ([] if colour else ["colour=off"])
        spec = "openni2:" + uri + ("?" + "&".join(options) if options else "")
        self._sequence = kfx.Sequence(spec)  # a kfx.Error names the device and the problem
        self.source = self._sequence.description
        self.camera = self._sequence.camera
        self.depth_units_m = 0.001  # the library reads OpenNI2's depth in millimetres
        self._colour = self._sequence.has_colour
        # Only a recording read frame by frame has a known length; it waits for kfx instead of
        # dropping. A camera, or a recording at its pace, never waits.
        self._start(queue_size, wait_when_full=self._sequence.frame_count >= 0)

    @property
    def has_colour(self) -> bool:
        return bool(self._colour)

    def _read(self) -> Optional[LiveFrame]:
        status, frame = self._sequence.read()  # waits for the device, the GIL released
        if status == kfx.ReadStatus.END:
            self.end_reason = "end of recording"
            raise StopIteration
        if status == kfx.ReadStatus.BAD_FRAME:
            with self._lock:
                self.stats.frames_bad += 1
            return None
        return LiveFrame(frame.depth, frame.colour if self._colour else None, frame.stamp,
                         frame.index, 1000.0)

    def _close(self) -> None:
        del self._sequence  # closes the device


def _write_atomically(path: pathlib.Path, text: str) -> None:
    temporary = path.with_name(path.name + ".tmp")
    temporary.write_text(text)
    os.replace(temporary, path)


def run(out: str, from_file: str = "", serial: str = "", backend: str = "auto",
        preset: str = "exact", settings: Optional[Dict[str, str]] = None, frames: int = 0,
        queue_size: int = 2, colour: bool = True, mesh: bool = True, real_time: bool = True,
        viewer: Optional[Any] = None, on_frame: Optional[Callable[[Any], None]] = None,
        stop: Optional[threading.Event] = None,
        on_start: Optional[Callable[[Any], None]] = None,
        openni: Optional[str] = None) -> LiveStats:
    """Reconstructs from the camera (or ``from_file`` at the camera's pace) until ``stop`` is
    set, ``frames`` frames are processed (0: no limit) or the recording ends; then writes
    ``out``/trajectory.txt, mesh.ply (unless ``mesh`` is False) and stats.json, and returns
    the stats. The camera is a RealSense one unless ``openni`` is given: ``""`` for the first
    OpenNI2 device, else its URI (an ``.oni`` path plays that recording as the device, at its
    pace unless ``real_time`` is False). ``viewer`` (a kfx.viewer.Viewer) is fed each frame off
    the frame loop; ``on_frame`` gets each FrameResult, ``on_start`` the camera once it runs."""
    if queue_size < 1:
        raise kfx.Error("the queue holds at least one frame")
    out_dir = pathlib.Path(out)
    stop = stop or threading.Event()
    camera: _LiveSource
    if openni is not None:
        if from_file or serial:
            raise kfx.Error("an OpenNI2 device is named by its URI (--openni URI, an "
                            ".oni path for a recording), not by --from-file or --serial")
        if not kfx.has_openni2():
            raise kfx.Error("this kfx was built without OpenNI2, which reads OpenNI2 "
                            "devices (--openni); install Debian's libopenni2-dev and rebuild "
                            "kfx")
        camera = OpenNI2Camera(openni, colour=colour, queue_size=queue_size,
                               real_time=real_time)
    else:
        camera = Camera(from_file, serial, colour=colour, queue_size=queue_size,
                        real_time=real_time)
    stats = camera.stats
    depth_scale = 1.0 / camera.depth_units_m
    started = None
    reconstruction = None
    try:
        # The camera's colour is fused unless the settings turn colour off (a reconstruction
        # without colour refuses a colour image, so none is passed then).
        live_settings = dict(settings or {})
        if camera.has_colour:
            live_settings.setdefault("colour", "on")
        use_colour = camera.has_colour and str(live_settings.get("colour")).lower() in ("on", "true")
        reconstruction = kfx.Reconstruction(camera=camera.camera, backend=backend, preset=preset,
                                            **live_settings)
        if on_start is not None:
            on_start(camera)
        while not stop.is_set():
            try:
                frame = camera.queue.get(timeout=0.2)
            except queue.Empty:
                if camera.running:
                    continue
                try:  # the camera stopped: what it sent last, or the end
                    frame = camera.queue.get_nowait()
                except queue.Empty:
                    frame = None
            if frame is None:
                stats.stopped_by = camera.end_reason or "camera stopped"
                if camera.error is not None:
                    raise kfx.Error(f"the camera failed: {camera.error}")
                break
            started = started or time.monotonic()
            result = reconstruction.process(frame.depth, frame.stamp, depth_scale,
                                            frame.colour if use_colour else None,
                                            input_index=frame.number)
            stats.frames_processed += 1
            if viewer is not None:
                viewer.submit(reconstruction, frame, result)
            if on_frame is not None:
                on_frame(result)
            if frames and stats.frames_processed >= frames:
                stats.stopped_by = "frame limit"
                break
        if stop.is_set():
            stats.stopped_by = getattr(stop, "reason", "") or "stopped"
    finally:
        camera.stop()
        while True:  # frames still waiting when stopped: received, not processed
            try:
                waiting = camera.queue.get_nowait()
            except queue.Empty:
                break
            if waiting is not None:
                stats.frames_dropped += 1
        out_dir.mkdir(parents=True, exist_ok=True)
        stats.seconds = time.monotonic() - started if started else 0.0
        stats.processed_per_s = stats.frames_processed / stats.seconds if stats.seconds else 0.0
        if viewer is not None:
            stats.viewer = viewer.close()
        if reconstruction is not None and stats.frames_processed:
            reconstruction.save_trajectory(str(out_dir / "trajectory.txt"), stats.source)
            if mesh:
                reconstruction.save_mesh(str(out_dir / "mesh.ply"), stats.source)
        _write_atomically(out_dir / "stats.json", json.dumps(asdict(stats), indent=2) + "\n")
    return stats


class _StopOnSignal:
    """Sets an event on SIGINT/SIGTERM (the frame loop then stops and writes its outputs)."""

    def __init__(self) -> None:
        self.event = threading.Event()
        for number in (signal.SIGINT, signal.SIGTERM):
            signal.signal(number, self._handle)

    def _handle(self, number: int, _frame: Any) -> None:
        self.event.reason = "signal " + signal.Signals(number).name  # type: ignore[attr-defined]
        self.event.set()


def main(argv: Optional[List[str]] = None) -> int:
    parser = argparse.ArgumentParser(
        prog="kfx live", description="Reconstructs live from a RealSense camera (pyrealsense2) "
        "or an OpenNI2 device (--openni: Kinect v1, Xtion, Orbbec), or from a recording played "
        "at the camera's pace, until Ctrl-C; writes trajectory.txt, mesh.ply and stats.json "
        "(frames received, processed and dropped).")
    parser.add_argument("--out", "-o", required=True, help="output folder")
    parser.add_argument("--from-file", default="",
                        help="a RealSense recording (.bag or .db3) to play as the camera")
    parser.add_argument("--serial", default="", help="the camera's serial number (default: any)")
    parser.add_argument("--openni", nargs="?", const="", default=None, metavar="URI",
                        help="an OpenNI2 device instead of a RealSense camera: the first one "
                             "OpenNI2 finds, or the one at URI; an .oni recording's path plays it "
                             "as the device at its recorded pace (needs kfx built with OpenNI2)")
    parser.add_argument("--backend", default="auto", help="cpu, cuda or auto")
    parser.add_argument("--preset", default="exact")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="any setting (see `kfx settings`); repeatable")
    parser.add_argument("--frames", type=int, default=0, help="stop after N frames (0: Ctrl-C)")
    parser.add_argument("--queue", type=int, default=2,
                        help="frames that may wait for the reconstruction (older ones are "
                             "dropped and counted)")
    parser.add_argument("--no-colour", action="store_true", help="depth only")
    parser.add_argument("--no-mesh", action="store_true", help="do not write mesh.ply")
    parser.add_argument("--fast-playback", action="store_true",
                        help="play --from-file (or an .oni given to --openni) as fast as it is "
                             "read, not at the camera's pace")
    parser.add_argument("--rerun", default="", metavar="FILE.rrd|spawn|HOST:PORT",
                        help="stream poses, depth, the tracking render and the model to Rerun: "
                             "an .rrd file, a viewer it spawns, or one listening at HOST:PORT")
    parser.add_argument("-q", "--quiet", action="store_true", help="no summary line")
    args = parser.parse_args(argv)
    settings = {}
    for pair in args.set:
        key, equals, value = pair.partition("=")
        if not equals:
            parser.error(f"--set '{pair}' is not key=value")
        settings[key] = value
    stop = _StopOnSignal()
    try:
        viewer = None
        if args.rerun:
            from kfx.viewer import Viewer  # noqa: PLC0415 (needs rerun-sdk)
            viewer = Viewer(args.rerun)
        stats = run(args.out, args.from_file, args.serial, args.backend, args.preset, settings,
                    args.frames, args.queue, not args.no_colour, not args.no_mesh,
                    not args.fast_playback, viewer, stop=stop.event, openni=args.openni,
                    on_start=None if args.quiet else lambda camera: print(
                        f"kfx live: reading {camera.source} ({camera.camera.width}x"
                        f"{camera.camera.height}); Ctrl-C stops and writes the outputs",
                        file=sys.stderr, flush=True))
    except kfx.Error as error:
        print(f"kfx live: error: {error}", file=sys.stderr)
        return 1
    if not args.quiet:
        print(f"kfx live: {stats.frames_processed} frames processed of {stats.frames_received} "
              f"received ({stats.frames_dropped} dropped by kfx, {stats.frames_missed} missed "
              f"by the camera), {stats.processed_per_s:.1f} frames/s; stopped by "
              f"{stats.stopped_by}; outputs in {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
