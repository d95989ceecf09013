"""ROS1 message definitions ("ros1msg" schemas) and ROS1 serializers for the zenav messages that have a
standard ROS1 type, so Foxglove Studio (or any ROS1 tool) opens our MCAP files.

ROS1 serialization: little-endian, no padding; ``string`` and variable arrays are a uint32 length then
the items; ``time`` is uint32 sec + uint32 nsec; fixed arrays (``float64[9]``) have no length. A schema is
the full message definition as in a ROS1 bag's connection header: the main definition, then every
dependency once (depth-first) after a line of 80 '=' and ``MSG: pkg/Type``.

Mapping (zenav -> ROS1): LaserScan, Odometry (covariances zero), TFMessage (tf2_msgs), OccupancyGrid,
Costmap (nav_msgs/OccupancyGrid through costmap_2d's cost translation table: lossy between the
special values, see ``COST_TO_OCC``), Path (planar poses -> geometry_msgs/PoseStamped[]), DepthImage
(sensor_msgs/Image 32FC1), CameraInfo (plumb_bob, no distortion), Twist, PoseStamped, Clock
(rosgraph_msgs). ``ros1_decode`` reads them back.
"""

from __future__ import annotations

import math
import re
import struct
from collections.abc import Callable
from typing import Any

import numpy as np

from common import messages as m

SEPARATOR = "=" * 80

# Base definitions (constants and comments left out: they do not change the wire format).
DEFINITIONS: dict[str, str] = {
    "std_msgs/Header": "uint32 seq\ntime stamp\nstring frame_id\n",
    "geometry_msgs/Vector3": "float64 x\nfloat64 y\nfloat64 z\n",
    "geometry_msgs/Point": "float64 x\nfloat64 y\nfloat64 z\n",
    "geometry_msgs/Quaternion": "float64 x\nfloat64 y\nfloat64 z\nfloat64 w\n",
    "geometry_msgs/Pose": "geometry_msgs/Point position\ngeometry_msgs/Quaternion orientation\n",
    "geometry_msgs/PoseWithCovariance": "geometry_msgs/Pose pose\nfloat64[36] covariance\n",
    "geometry_msgs/Twist": "geometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular\n",
    "geometry_msgs/TwistWithCovariance": "geometry_msgs/Twist twist\nfloat64[36] covariance\n",
    "geometry_msgs/Transform": "geometry_msgs/Vector3 translation\ngeometry_msgs/Quaternion rotation\n",
    "geometry_msgs/TransformStamped":
        "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/Transform transform\n",
    "geometry_msgs/PoseStamped": "std_msgs/Header header\ngeometry_msgs/Pose pose\n",
    "tf2_msgs/TFMessage": "geometry_msgs/TransformStamped[] transforms\n",
    "sensor_msgs/LaserScan":
        "std_msgs/Header header\nfloat32 angle_min\nfloat32 angle_max\nfloat32 angle_increment\n"
        "float32 time_increment\nfloat32 scan_time\nfloat32 range_min\nfloat32 range_max\n"
        "float32[] ranges\nfloat32[] intensities\n",
    "nav_msgs/Odometry": "std_msgs/Header header\nstring child_frame_id\n"
        "geometry_msgs/PoseWithCovariance pose\ngeometry_msgs/TwistWithCovariance twist\n",
    "nav_msgs/MapMetaData":
        "time map_load_time\nfloat32 resolution\nuint32 width\nuint32 height\ngeometry_msgs/Pose origin\n",
    "nav_msgs/OccupancyGrid": "std_msgs/Header header\nnav_msgs/MapMetaData info\nint8[] data\n",
    "nav_msgs/Path": "std_msgs/Header header\ngeometry_msgs/PoseStamped[] poses\n",
    "sensor_msgs/Image": "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\n"
        "uint8 is_bigendian\nuint32 step\nuint8[] data\n",
    "sensor_msgs/RegionOfInterest":
        "uint32 x_offset\nuint32 y_offset\nuint32 height\nuint32 width\nbool do_rectify\n",
    "sensor_msgs/CameraInfo": "std_msgs/Header header\nuint32 height\nuint32 width\nstring distortion_model\n"
        "float64[] D\nfloat64[9] K\nfloat64[9] R\nfloat64[12] P\nuint32 binning_x\nuint32 binning_y\n"
        "sensor_msgs/RegionOfInterest roi\n",
    "rosgraph_msgs/Clock": "time clock\n",
}

# zenav message type -> ROS1 type it is written as
ROS_TYPES: dict[str, str] = {
    "LaserScan": "sensor_msgs/LaserScan", "Odometry": "nav_msgs/Odometry", "TFMessage": "tf2_msgs/TFMessage",
    "OccupancyGrid": "nav_msgs/OccupancyGrid", "Costmap": "nav_msgs/OccupancyGrid", "Path": "nav_msgs/Path",
    "DepthImage": "sensor_msgs/Image", "CameraInfo": "sensor_msgs/CameraInfo", "Twist": "geometry_msgs/Twist",
    "PoseStamped": "geometry_msgs/PoseStamped", "Clock": "rosgraph_msgs/Clock",
}

# ROS1 md5sum of each type (channel metadata ``md5sum``, as the MCAP ros1 profile and bag tools expect)
MD5SUMS: dict[str, str] = {
    "sensor_msgs/LaserScan": "90c7ef2dc6895d81024acba2ac42f369",
    "nav_msgs/Odometry": "cd5e73d190d741a2f92e81eda573aca7",
    "tf2_msgs/TFMessage": "94810edda583a504dfda3829e70d7eec",
    "nav_msgs/OccupancyGrid": "3381f2d731d4076ec5c71b0759edbe4e",
    "nav_msgs/Path": "6227e2b7e9cce15051f669a5e197bbf7",
    "sensor_msgs/Image": "060021388200f6f0f447d0fcd9c64743",
    "sensor_msgs/CameraInfo": "c9a58c1b0b154e0e6da7578cb991d214",
    "geometry_msgs/Twist": "9f195f881246fdfa2798d1d3eebca84a",
    "geometry_msgs/PoseStamped": "d3812c3cbc69362b77dc0b19b345f8f5",
    "rosgraph_msgs/Clock": "a9c97c1d230cfc112e270351a944ee47",
}

_FIELD_TYPE = re.compile(r"^\s*([A-Za-z0-9_/]+)(\[\d*\])?\s+\w+", re.M)


def _deps(name: str, out: list[str]) -> None:
    for t, _ in _FIELD_TYPE.findall(DEFINITIONS[name]):
        if "/" in t and t not in out:
            out.append(t)
            _deps(t, out)


def full_definition(ros_type: str) -> str:
    """The ros1msg schema text of ``ros_type`` (e.g. ``nav_msgs/Odometry``) with its dependencies."""
    deps: list[str] = []
    _deps(ros_type, deps)
    return DEFINITIONS[ros_type] + "".join(f"{SEPARATOR}\nMSG: {d}\n{DEFINITIONS[d]}" for d in deps)


# costmap_2d's Costmap2DPublisher: 0 free, 1..252 -> 1..98, 253 inscribed -> 99, 254 lethal -> 100, 255 -> -1
COST_TO_OCC = np.array([0] + [1 + (97 * (i - 1)) // 251 for i in range(1, 253)] + [99, 100, -1], np.int8)


# -- primitives ------------------------------------------------------------------------------------
_U32 = struct.Struct("<I")
_TIME = struct.Struct("<II")
_F64X3 = struct.Struct("<3d")
_F64X4 = struct.Struct("<4d")
_F64X7 = struct.Struct("<7d")
_ZERO_COV = bytes(8 * 36)


def time_parts(t: float) -> tuple[int, int]:
    """Seconds -> (sec, nsec) of a ROS1 ``time`` (0 for negative / non-finite; saturated at uint32)."""
    if not (t > 0 and math.isfinite(t)):
        return 0, 0
    sec = int(t)
    nsec = int(round((t - sec) * 1e9))
    if nsec >= 1_000_000_000:
        sec, nsec = sec + 1, nsec - 1_000_000_000
    return (sec, nsec) if sec < 2**32 else (2**32 - 1, 999_999_999)


def _time(t: float) -> bytes:
    return _TIME.pack(*time_parts(t))


def _string(s: str) -> bytes:
    b = s.encode()
    return _U32.pack(len(b)) + b


def _header(h: m.Header) -> bytes:
    return b"\0\0\0\0" + _time(h.stamp) + _string(h.frame_id)


def _array(a: np.ndarray, dtype: str) -> bytes:
    a = np.ascontiguousarray(a, dtype=dtype)
    return _U32.pack(a.size) + a.tobytes()


def _pose(t: m.Transform) -> bytes:
    v, q = t.translation, t.rotation
    return _F64X7.pack(v.x, v.y, v.z, q.x, q.y, q.z, q.w)


def _pose2d(p: m.Pose2D) -> bytes:
    return _F64X7.pack(p.x, p.y, 0.0, 0.0, 0.0, math.sin(p.theta / 2), math.cos(p.theta / 2))


def _twist(t: m.Twist) -> bytes:
    return _F64X3.pack(t.linear.x, t.linear.y, t.linear.z) + _F64X3.pack(t.angular.x, t.angular.y, t.angular.z)


# -- serializers -----------------------------------------------------------------------------------
def _laser_scan(s: m.LaserScan) -> bytes:
    head = np.array([s.angle_min, s.angle_max, s.angle_increment, s.time_increment, s.scan_time, s.range_min,
                     s.range_max], "<f4").tobytes()  # numpy: out-of-range values become inf, as in C++
    return _header(s.header) + head + _array(s.ranges, "<f4") + _array(s.intensities, "<f4")


def _odometry(o: m.Odometry) -> bytes:
    return _header(o.header) + _string(o.child_frame_id) + _pose(o.pose) + _ZERO_COV + _twist(o.twist) + _ZERO_COV


def _tf_message(t: m.TFMessage) -> bytes:
    parts = [_U32.pack(len(t.transforms))]
    for ts in t.transforms:
        parts += [_header(ts.header), _string(ts.child_frame_id), _pose(ts.transform)]
    return b"".join(parts)


def _grid(header: m.Header, resolution: float, origin: m.Pose2D, data: np.ndarray) -> bytes:
    h, w = data.shape
    info = _time(header.stamp) + np.float32(resolution).tobytes() + struct.pack("<II", w, h) + _pose2d(origin)
    return _header(header) + info + _array(data, "<i1")


def _occupancy_grid(g: m.OccupancyGrid) -> bytes:
    return _grid(g.header, g.resolution, g.origin, g.data)


def _costmap(c: m.Costmap) -> bytes:
    return _grid(c.header, c.resolution, c.origin, COST_TO_OCC[np.asarray(c.data, np.uint8)])


def _path(p: m.Path) -> bytes:
    """geometry_msgs/PoseStamped[] in one numpy buffer (every pose carries the path's header)."""
    frame = p.header.frame_id.encode()
    sec, nsec = time_parts(p.header.stamp)
    fields = [("seq", "<u4"), ("sec", "<u4"), ("nsec", "<u4"), ("flen", "<u4")]
    fields += [("frame", f"S{len(frame)}")] if frame else []
    rows = np.zeros(len(p.poses), np.dtype([*fields, ("pose", "<f8", (7,))]))
    rows["sec"], rows["nsec"], rows["flen"] = sec, nsec, len(frame)
    if frame:
        rows["frame"] = frame
    poses = np.asarray(p.poses, np.float64).reshape(-1, 3)
    rows["pose"][:, 0:2] = poses[:, 0:2]
    rows["pose"][:, 5] = np.sin(poses[:, 2] / 2)
    rows["pose"][:, 6] = np.cos(poses[:, 2] / 2)
    return _header(p.header) + _U32.pack(len(rows)) + rows.tobytes()


def _depth_image(d: m.DepthImage) -> bytes:
    h, w = d.depth.shape
    head = struct.pack("<II", h, w) + _string("32FC1") + struct.pack("<BI", 0, w * 4)
    data = np.ascontiguousarray(d.depth, "<f4").tobytes()  # uint8[]: the length counts bytes
    return _header(d.header) + head + _U32.pack(len(data)) + data


def _camera_info(c: m.CameraInfo) -> bytes:
    k = (c.fx, 0.0, c.cx, 0.0, c.fy, c.cy, 0.0, 0.0, 1.0)
    r = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    p = (c.fx, 0.0, c.cx, 0.0, 0.0, c.fy, c.cy, 0.0, 0.0, 0.0, 1.0, 0.0)
    return (_header(c.header) + struct.pack("<II", c.height, c.width) + _string("plumb_bob")
            + struct.pack("<I5d", 5, *(0.0,) * 5) + struct.pack("<30d", *k, *r, *p)
            + struct.pack("<II4IB", 0, 0, 0, 0, 0, 0, 0))


def _pose_stamped(p: m.PoseStamped) -> bytes:
    return _header(p.header) + _pose(p.pose)


SERIALIZERS: dict[str, Callable[[Any], bytes]] = {
    "LaserScan": _laser_scan, "Odometry": _odometry, "TFMessage": _tf_message, "OccupancyGrid": _occupancy_grid,
    "Costmap": _costmap, "Path": _path, "DepthImage": _depth_image, "CameraInfo": _camera_info,
    "Twist": _twist, "PoseStamped": _pose_stamped, "Clock": lambda c: _time(c.clock),
}


def serialize(msg) -> tuple[str, bytes] | None:
    """(ROS1 type, ROS1 bytes) of a zenav message, or None when it has no standard ROS1 type."""
    name = getattr(type(msg), "_msg_name", "")
    fn = SERIALIZERS.get(name)
    return None if fn is None else (ROS_TYPES[name], fn(msg))
