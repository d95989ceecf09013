"""ROS1 deserializers: ROS1 bytes of a standard type -> the zenav message (the inverse of ``ros1_msgs``).

They read what any ROS1 tool writes for the type (rosbag, mcap_ros1, Foxglove), not only our own files:
``Image`` in 32FC1 (either byte order) or 16UC1 / mono16 (millimetres) becomes a ``DepthImage``; an
``OccupancyGrid`` becomes a ``Costmap`` when asked (our channel metadata says so, or the topic is a
costmap_2d topic), inverting costmap_2d's translation table. ``Ros1DecodeError`` for anything else
(truncated bytes, trailing bytes, an encoding we cannot map).
"""

from __future__ import annotations

import math
import struct

import numpy as np

from common import messages as m
from deploy.logs.ros1_msgs import COST_TO_OCC


class Ros1DecodeError(ValueError):
    """ROS1 bytes that are not a valid message of the type, or that zenav has no message for."""


def _occ_to_cost() -> np.ndarray:
    """Occupancy value (as uint8 index) -> the middle of the costs that map to it (exact for 0, 99, 100, -1)."""
    table = np.full(256, 255, np.uint8)  # out-of-range occupancy values: unknown
    occ = COST_TO_OCC.astype(np.int16)
    for v in range(-1, 101):
        costs = np.flatnonzero(occ == v)
        if costs.size:
            table[v & 0xFF] = costs[(costs.size - 1) // 2]
    return table


OCC_TO_COST = _occ_to_cost()


def _f32(v: float) -> float:
    """A float32 field as the shortest decimal that round-trips it (0.05 stays 0.05, not 0.0500000007)."""
    return float(str(np.float32(v)))


class _Reader:
    __slots__ = ("buf", "pos")

    def __init__(self, data: bytes | memoryview) -> None:
        self.buf = memoryview(data).cast("B")
        self.pos = 0

    def unpack(self, st: struct.Struct) -> tuple:
        if self.pos + st.size > len(self.buf):
            raise Ros1DecodeError(f"truncated: need {st.size} bytes at offset {self.pos} of {len(self.buf)}")
        v = st.unpack_from(self.buf, self.pos)
        self.pos += st.size
        return v

    def take(self, n: int) -> memoryview:
        if n < 0 or self.pos + n > len(self.buf):
            raise Ros1DecodeError(f"truncated: need {n} bytes at offset {self.pos} of {len(self.buf)}")
        v = self.buf[self.pos : self.pos + n]
        self.pos += n
        return v

    def u32(self) -> int:
        return self.unpack(_U32)[0]

    def time(self) -> float:
        sec, nsec = self.unpack(_TIME)
        return sec + nsec * 1e-9

    def string(self) -> str:
        return bytes(self.take(self.u32())).decode("utf-8", errors="replace")

    def array(self, dtype: str, count: int | None = None) -> np.ndarray:
        dt = np.dtype(dtype)
        n = self.u32() if count is None else count
        return np.frombuffer(self.take(n * dt.itemsize), dt).astype(dt.newbyteorder("="), copy=True)

    def header(self) -> m.Header:
        self.u32()  # seq
        stamp = self.time()
        return m.Header(stamp, self.string())

    def transform(self) -> m.Transform:
        x, y, z, qx, qy, qz, qw = self.unpack(_F64X7)
        return m.Transform(m.Vector3(x, y, z), m.Quaternion(qx, qy, qz, qw))

    def twist(self) -> m.Twist:
        lx, ly, lz, ax, ay, az = self.unpack(_F64X6)
        return m.Twist(m.Vector3(lx, ly, lz), m.Vector3(ax, ay, az))

    def end(self, msg):
        if self.pos != len(self.buf):
            raise Ros1DecodeError(f"{len(self.buf) - self.pos} trailing bytes")
        return msg


_U32 = struct.Struct("<I")
_TIME = struct.Struct("<II")
_F64X6 = struct.Struct("<6d")
_F64X7 = struct.Struct("<7d")
_F32X7 = struct.Struct("<7f")
_GRID_INFO = struct.Struct("<IIfII7d")


def _laser_scan(r: _Reader) -> m.LaserScan:
    h = r.header()
    a_min, a_max, a_inc, t_inc, scan_t, r_min, r_max = (_f32(v) for v in r.unpack(_F32X7))
    return m.LaserScan(h, a_min, a_max, a_inc, t_inc, scan_t, r_min, r_max,
                       ranges=r.array("<f4"), intensities=r.array("<f4"))


def _odometry(r: _Reader) -> m.Odometry:
    h, child, pose = r.header(), r.string(), r.transform()
    r.take(8 * 36)
    twist = r.twist()
    r.take(8 * 36)
    return m.Odometry(h, child, pose, twist)


def _tf_message(r: _Reader) -> m.TFMessage:
    n = r.u32()
    if n > len(r.buf):  # every transform is > 1 byte: a hostile count
        raise Ros1DecodeError(f"{n} transforms in {len(r.buf)} bytes")
    return m.TFMessage(tuple(m.TransformStamped(r.header(), r.string(), r.transform()) for _ in range(n)))


def _yaw(qx: float, qy: float, qz: float, qw: float) -> float:
    return math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))


def _grid(r: _Reader, costmap: bool):
    h = r.header()
    _, _, res, w, hh, x, y, _z, qx, qy, qz, qw = r.unpack(_GRID_INFO)
    data = r.array("<i1")
    if data.size != w * hh:
        raise Ros1DecodeError(f"OccupancyGrid: {data.size} cells for {w} x {hh}")
    origin = m.Pose2D(x, y, _yaw(qx, qy, qz, qw))
    grid = data.reshape(hh, w)
    if costmap:
        return m.Costmap(h, _f32(res), origin, OCC_TO_COST[grid.view(np.uint8)])
    return m.OccupancyGrid(h, _f32(res), origin, grid)


def _path(r: _Reader) -> m.Path:
    h = r.header()
    n = r.u32()
    if n * 72 > len(r.buf):  # a PoseStamped is at least 72 bytes
        raise Ros1DecodeError(f"{n} poses in {len(r.buf)} bytes")
    poses = np.zeros((n, 3))
    for i in range(n):
        r.header()
        x, y, _z, qx, qy, qz, qw = r.unpack(_F64X7)
        poses[i] = x, y, _yaw(qx, qy, qz, qw)
    return m.Path(h, poses)


def _image(r: _Reader) -> m.DepthImage:
    h = r.header()
    height, width = r.unpack(_II)
    encoding = r.string()
    big, step = r.unpack(_BI)
    size = r.u32()
    data = r.take(size)
    kinds = {"32FC1": ("f4", 1.0), "16UC1": ("u2", 0.001), "mono16": ("u2", 0.001)}
    if encoding not in kinds:
        raise Ros1DecodeError(f"Image encoding {encoding!r} is not a depth image (32FC1, 16UC1)")
    kind, scale = kinds[encoding]
    dt = np.dtype((">" if big else "<") + kind)
    if step < width * dt.itemsize or size != step * height:
        raise Ros1DecodeError(f"Image: {size} bytes for {height} rows of step {step} ({width} x {encoding})")
    rows = np.frombuffer(data, np.uint8).reshape(height, step)[:, : width * dt.itemsize]
    depth = np.ascontiguousarray(rows).view(dt).reshape(height, width)
    return m.DepthImage(h, (depth * scale if scale != 1.0 else depth).astype(np.float32))


_II = struct.Struct("<II")
_BI = struct.Struct("<BI")


def _camera_info(r: _Reader) -> m.CameraInfo:
    h = r.header()
    height, width = r.unpack(_II)
    r.string()  # distortion model: zenav keeps the pinhole part only
    r.array("<f8")  # D
    k = r.array("<f8", 9)
    r.take(8 * (9 + 12) + 4 * 6 + 1)  # R, P, binning, roi
    return m.CameraInfo(h, width, height, float(k[0]), float(k[4]), float(k[2]), float(k[5]))


def _pose_stamped(r: _Reader) -> m.PoseStamped:
    return m.PoseStamped(r.header(), r.transform())


DESERIALIZERS = {
    "sensor_msgs/LaserScan": _laser_scan, "nav_msgs/Odometry": _odometry, "tf2_msgs/TFMessage": _tf_message,
    "nav_msgs/Path": _path, "sensor_msgs/Image": _image, "sensor_msgs/CameraInfo": _camera_info,
    "geometry_msgs/Twist": _Reader.twist, "geometry_msgs/PoseStamped": _pose_stamped,
    "rosgraph_msgs/Clock": lambda r: m.Clock(r.time()),
}


def ros_type_name(name: str) -> str:
    """``sensor_msgs/msg/LaserScan`` (ROS 2 style, used by some tools) -> ``sensor_msgs/LaserScan``."""
    return name.replace("/msg/", "/")


def can_decode(ros_type: str) -> bool:
    t = ros_type_name(ros_type)
    return t in DESERIALIZERS or t == "nav_msgs/OccupancyGrid"


def deserialize(ros_type: str, data: bytes | memoryview, costmap: bool = False):
    """The zenav message for ROS1 bytes of ``ros_type``; ``costmap``: an OccupancyGrid as a ``Costmap``."""
    t = ros_type_name(ros_type)
    r = _Reader(data)
    try:
        if t == "nav_msgs/OccupancyGrid":
            return r.end(_grid(r, costmap))
        fn = DESERIALIZERS.get(t)
        if fn is None:
            raise ValueError("no zenav message for this ROS type")
        return r.end(fn(r))
    except (struct.error, ValueError, TypeError, MemoryError) as e:  # Ros1DecodeError included
        raise Ros1DecodeError(f"{t}: {e}") from e
