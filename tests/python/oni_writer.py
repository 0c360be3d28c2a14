"""Writes OpenNI 2 recordings (.oni) for tests: no camera or recorder exists here to make one.

Written from the file format as OpenNI 2's own player (its OniFile driver) reads it: a 24-byte
header ("NI10", format version 1.0.1.0, the largest timestamp, the largest node id), then records,
each a 28-byte header (magic "NIR\\0", type, node id, size of header and fields, payload size,
position of the record it undoes) followed by its fields and payload. A node (one per stream) is
added with its name, type, codec, frame count and timestamps, then its properties (video mode,
pixel format, field of view, cropping), then "state ready"; then its frames ("new data": the
timestamp in microseconds, the frame number, the pixels as the payload), and an end record.
Frames are stored uncompressed (codec "NONE"), which the player reads as it reads a camera's.
"""

import struct

import numpy as np

_RECORD_MAGIC = 0x0052494E
_INT_PROPERTY, _GENERAL_PROPERTY = 0x03, 0x06
_NODE_STATE_READY, _NODE_DATA_BEGIN, _NEW_DATA, _END, _NODE_ADDED = 0x09, 0x08, 0x0A, 0x0B, 0x0D
_DEPTH_NODE, _IMAGE_NODE = 2, 3
_PIXEL_DEPTH_1_MM, _PIXEL_RGB888 = 100, 200


def _codec(name):
    a, b, c, d = name.encode()
    return a | b << 8 | c << 16 | d << 24


def _string(text):
    data = text.encode() + b"\0"
    return struct.pack("<I", len(data)) + data


class _Writer:
    def __init__(self, path):
        self.file = open(path, "wb")
        self.file.write(b"\0" * 24)  # the header, written last (it holds the maxima)

    def record(self, kind, node, fields=b"", payload=b""):
        self.file.write(struct.pack("<IIIIIQ", _RECORD_MAGIC, kind, node, 28 + len(fields),
                                    len(payload), 0) + fields + payload)

    def prop_int(self, node, name, value):
        self.record(_INT_PROPERTY, node, _string(name) + struct.pack("<IQ", 8, value))

    def prop_general(self, node, name, data):
        self.record(_GENERAL_PROPERTY, node, _string(name) + struct.pack("<I", len(data)) + data)


def write_oni(path, depth_mm, stamps_us, hfov_rad, vfov_rad, colour=None, fps=30,
              truncate_last=0):
    """Writes `depth_mm` (N, H, W) uint16 and, when given, `colour` (N, H, W, 3) uint8 as an
    OpenNI 2 recording with the field of view `hfov_rad` x `vfov_rad`; `truncate_last` cuts that
    many bytes off the end (a recording that stopped mid-frame)."""
    depth_mm = np.ascontiguousarray(depth_mm, np.uint16)
    n, height, width = depth_mm.shape
    nodes = [("Depth", _DEPTH_NODE, _PIXEL_DEPTH_1_MM, depth_mm)]
    if colour is not None:
        nodes.append(("Image", _IMAGE_NODE, _PIXEL_RGB888, np.ascontiguousarray(colour, np.uint8)))
    stamps = [int(s) for s in stamps_us]
    w = _Writer(path)
    for node, (name, kind, pixel_format, _) in enumerate(nodes):
        w.record(_NODE_ADDED, node, _string(name) + struct.pack(
            "<iIIQQQ", kind, _codec("NONE"), n, stamps[0], stamps[-1], 0))
        w.prop_general(node, "xnMapOutputMode", struct.pack("<III", width, height, fps))
        w.prop_int(node, "oniPixelFormat", pixel_format)
        w.prop_general(node, "xnCropping", struct.pack("<IHHHH", 0, 0, 0, 0, 0))
        w.prop_int(node, "RequiredDataSize", nodes[node][3][0].nbytes)
        w.prop_general(node, "xnFOV", struct.pack("<dd", hfov_rad, vfov_rad))
        w.record(_NODE_STATE_READY, node)
    for node in range(len(nodes)):
        w.record(_NODE_DATA_BEGIN, node, struct.pack("<IQ", n, stamps[-1]))
    for i in range(n):
        for node, (_, _, _, frames) in enumerate(nodes):
            w.record(_NEW_DATA, node, struct.pack("<QI", stamps[i], i + 1), frames[i].tobytes())
    w.record(_END, 0)
    w.file.seek(0)
    w.file.write(b"NI10" + struct.pack("<BBHIQI", 1, 0, 1, 0, stamps[-1], len(nodes) - 1))
    w.file.close()
    if truncate_last:
        with open(path, "r+b") as f:
            f.seek(0, 2)
            f.truncate(f.tell() - truncate_last)
