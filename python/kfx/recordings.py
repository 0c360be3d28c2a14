"""Recordings written from any kfx input, as a camera driver would record them: ROS 1 and ROS 2
bags (``rosbags``, ``pip install kfx[ros]``) and RealSense bags (``pyrealsense2``,
``pip install kfx[realsense]``). kfx reads all three back as inputs; these writers let a dataset
stand in for a camera (tests, demos, replays at real time).

Depth is written in millimetres (16UC1, or z16 with 1 mm Depth Units), colour as rgb8, the
camera as the recording's CameraInfo / RealSense intrinsics, and each frame's stamp as its
header stamp (seconds).
"""

from __future__ import annotations

import os
import pathlib
import time
from typing import Any, Iterator, Optional, Tuple

import numpy as np

import kfx

#: Default topics of the ROS writers (those of the ROS camera drivers).
DEPTH_TOPIC = "/camera/depth/image_raw"
COLOUR_TOPIC = "/camera/color/image_raw"


def _need(module: str, extra: str) -> Any:
    try:
        return __import__(module, fromlist=["_"])
    except ImportError as error:
        raise ImportError(f"kfx: writing this recording needs the PyPI package '{module}' "
                          f"(pip install kfx[{extra}])") from error


def _frames(input: str, frames: Optional[int]) -> Tuple[kfx.Camera, Iterator[Any]]:
    sequence = kfx.open(input)
    camera = sequence.camera
    if camera is None:
        raise kfx.Error(f"input '{input}' has no camera of its own to record")

    def take() -> Iterator[Any]:
        for i, frame in enumerate(sequence):
            if frames is not None and i >= frames:
                return
            yield frame

    return camera, take()


def _stamp(seconds: float) -> Tuple[int, int]:
    nanoseconds = int(round(seconds * 1e9))
    return nanoseconds // 1_000_000_000, nanoseconds % 1_000_000_000


def _write_ros(input: str, path: str, frames: Optional[int], ros2: bool, depth_topic: str,
               colour_topic: str, compression: str) -> int:
    typesys = _need("rosbags.typesys", "ros")
    if ros2:
        store = typesys.get_typestore(typesys.Stores.ROS2_HUMBLE)
        writer_module = _need("rosbags.rosbag2", "ros")
        writer = writer_module.Writer(path, version=8)
    else:
        store = typesys.get_typestore(typesys.Stores.ROS1_NOETIC)
        writer_module = _need("rosbags.rosbag1", "ros")
        writer = writer_module.Writer(path)
        if compression != "none":
            writer.set_compression(getattr(writer.CompressionFormat, compression.upper()))
    serialize = store.serialize_cdr if ros2 else store.serialize_ros1
    types = store.types
    Image, CameraInfo = types["sensor_msgs/msg/Image"], types["sensor_msgs/msg/CameraInfo"]
    Header, Time = types["std_msgs/msg/Header"], types["builtin_interfaces/msg/Time"]
    Roi = types["sensor_msgs/msg/RegionOfInterest"]

    def header(stamp_s: float, frame_id: str) -> Any:
        sec, nanosec = _stamp(stamp_s)
        time = Time(sec=sec, nanosec=nanosec)
        return Header(stamp=time, frame_id=frame_id) if ros2 else Header(
            seq=0, stamp=time, frame_id=frame_id)

    def info(stamp_s: float, camera: kfx.Camera, frame_id: str) -> Any:
        k = np.array([camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1], np.float64)
        r = np.eye(3).reshape(9)
        p = np.array([camera.fx, 0, camera.cx, 0, 0, camera.fy, camera.cy, 0, 0, 0, 1, 0],
                     np.float64)
        d = np.array(list(camera.distortion), np.float64)
        fields = dict(header=header(stamp_s, frame_id), height=camera.height, width=camera.width,
                      distortion_model="plumb_bob", binning_x=0, binning_y=0,
                      roi=Roi(x_offset=0, y_offset=0, height=0, width=0, do_rectify=False))
        names = ("d", "k", "r", "p") if ros2 else ("D", "K", "R", "P")
        fields.update(zip(names, (d, k, r, p)))
        return CameraInfo(**fields)

    def image(stamp_s: float, pixels: np.ndarray, encoding: str, frame_id: str) -> Any:
        pixels = np.ascontiguousarray(pixels)
        return Image(header=header(stamp_s, frame_id), height=pixels.shape[0],
                     width=pixels.shape[1], encoding=encoding, is_bigendian=0,
                     step=pixels.strides[0], data=pixels.view(np.uint8).reshape(-1))

    camera, source = _frames(input, frames)
    parent = lambda topic: topic.rsplit("/", 1)[0]  # noqa: E731
    count = 0
    with writer:
        def connection(topic: str, msgtype: Any) -> Any:
            return writer.add_connection(topic, msgtype.__msgtype__, typestore=store)

        depth_connection = connection(depth_topic, Image)
        depth_info = connection(parent(depth_topic) + "/camera_info", CameraInfo)
        colour_connection = colour_info = None
        for frame in source:
            time_ns = int(round(frame.stamp * 1e9))
            writer.write(depth_info, time_ns,
                         serialize(info(frame.stamp, camera, "depth"), CameraInfo.__msgtype__))
            writer.write(depth_connection, time_ns,
                         serialize(image(frame.stamp, frame.depth, "16UC1", "depth"),
                                   Image.__msgtype__))
            if frame.colour is not None:
                if colour_connection is None:
                    colour_connection = connection(colour_topic, Image)
                    colour_info = connection(parent(colour_topic) + "/camera_info", CameraInfo)
                writer.write(colour_info, time_ns,
                             serialize(info(frame.stamp, camera, "depth"),
                                       CameraInfo.__msgtype__))
                writer.write(colour_connection, time_ns,
                             serialize(image(frame.stamp, frame.colour, "rgb8", "depth"),
                                       Image.__msgtype__))
            count += 1
    return count


def write_ros1_bag(input: str, path: str, frames: Optional[int] = None,
                   depth_topic: str = DEPTH_TOPIC, colour_topic: str = COLOUR_TOPIC,
                   compression: str = "none") -> int:
    """Writes the first ``frames`` frames of ``input`` (all when None) as a ROS 1 bag at
    ``path`` (chunks compressed with ``compression``: none, bz2 or lz4). Returns the frames
    written."""
    return _write_ros(input, path, frames, False, depth_topic, colour_topic, compression)


def write_ros2_bag(input: str, path: str, frames: Optional[int] = None,
                   depth_topic: str = DEPTH_TOPIC, colour_topic: str = COLOUR_TOPIC) -> int:
    """Writes the first ``frames`` frames of ``input`` as a ROS 2 bag (a rosbag2 folder,
    sqlite3 storage) at ``path``, which must not exist. Returns the frames written."""
    return _write_ros(input, path, frames, True, depth_topic, colour_topic, "none")


def write_realsense_bag(input: str, path: str, frames: Optional[int] = None,
                        fps: int = 30, paced: bool = False,
                        depth_to_colour: Optional[Tuple[Any, Any]] = None) -> int:
    """Writes the first ``frames`` frames of ``input`` (all when None) as a RealSense recording
    at ``path`` through librealsense's own recorder (``pyrealsense2``'s software device): z16
    depth with 1 mm Depth Units, rgb8 colour registered to it, the camera as both streams'
    intrinsics. pyrealsense2 up to 2.56 writes its ROS 1 form (``.bag``), later ones its ROS 2
    form (``path`` must end in ``.db3``). Frames are stamped with the input's stamps, or with
    ``paced`` at ``fps`` and recorded at that pace (a camera's recording to replay in real
    time). ``depth_to_colour`` = (R, t), a 3×3 rotation and a translation in metres with
    p_colour = R p_depth + t, is recorded as the streams' extrinsic instead of identity (the
    images stay registered: it tests what a reader makes of the extrinsic). Returns the frames
    written."""
    rs = _need("pyrealsense2", "realsense")
    camera, source = _frames(input, frames)
    source = list(source)
    device = rs.software_device()
    depth_sensor = device.add_sensor("Depth")
    colour_sensor = device.add_sensor("Color") if source and source[0].colour is not None else None

    def intrinsics() -> Any:
        k = rs.intrinsics()
        k.width, k.height = camera.width, camera.height
        k.fx, k.fy, k.ppx, k.ppy = camera.fx, camera.fy, camera.cx, camera.cy
        k.model = rs.distortion.brown_conrady
        k.coeffs = [float(c) for c in camera.distortion]
        return k

    def stream(kind: Any, fmt: Any, bpp: int, uid: int) -> Any:
        s = rs.video_stream()
        s.type, s.index, s.uid = kind, 0, uid
        s.width, s.height, s.fps, s.bpp, s.fmt = camera.width, camera.height, fps, bpp, fmt
        s.intrinsics = intrinsics()
        return s

    depth_profile = depth_sensor.add_video_stream(stream(rs.stream.depth, rs.format.z16, 2, 0))
    depth_sensor.add_read_only_option(rs.option.depth_units, 0.001)
    colour_profile = None
    if colour_sensor is not None:
        colour_profile = colour_sensor.add_video_stream(
            stream(rs.stream.color, rs.format.rgb8, 3, 1))
        rotation, translation = depth_to_colour or (np.eye(3), np.zeros(3))
        extrinsic = rs.extrinsics()
        # librealsense keeps the rotation column-major.
        extrinsic.rotation = [float(v) for v in np.asarray(rotation, np.float64).T.reshape(9)]
        extrinsic.translation = [float(v) for v in np.asarray(translation, np.float64)]
        depth_profile.register_extrinsics_to(colour_profile, extrinsic)
    recorder = rs.recorder(os.fspath(pathlib.Path(path)), device)
    sensors = [(depth_sensor, depth_profile)]
    if colour_sensor is not None:
        sensors.append((colour_sensor, colour_profile))
    for sensor, profile in sensors:
        sensor.open(profile)
        sensor.start(lambda f: None)

    def send(sensor: Any, profile: Any, pixels: np.ndarray, bpp: int, frame: Any) -> None:
        out = rs.software_video_frame()
        out.pixels = np.ascontiguousarray(pixels)
        out.bpp, out.stride = bpp, bpp * camera.width
        out.timestamp = frame.index * 1000.0 / fps if paced else frame.stamp * 1000.0
        out.domain = rs.timestamp_domain.hardware_clock
        out.frame_number = frame.index
        out.profile = profile.as_video_stream_profile()
        sensor.on_video_frame(out)

    start = time.monotonic()
    for frame in source:
        if paced:
            time.sleep(max(0.0, start + frame.index / fps - time.monotonic()))
        send(depth_sensor, depth_profile, frame.depth, 2, frame)
        if colour_sensor is not None:
            send(colour_sensor, colour_profile, frame.colour, 3, frame)
    for sensor, _ in sensors:
        sensor.stop()
        sensor.close()
    del recorder  # the recorder writes the bag's index when it is destroyed
    return len(source)
