"""Robot log formats, parsed once: CARMEN text logs (.clf / .log) and ROS1 bags -> common.messages.

Two readers build on this: ``master_side.slam.logs`` (the scans with the odometry pose, for SLAM) and
``deploy.logs.readers`` (every played message on its topic, for `zenav play`).

- CARMEN: ``carmen_laser`` (a FLASER / ROBOTLASER1 line -> ScanRecord), ``carmen_odom`` (ODOM -> Odometry),
  ``read_carmen_lines`` (a file's lines of the given types, parsed) and ``carmen_span`` (stamps and counts).
- ROS1 bags (rosbags): ``bag_reader``, ``bag_typestore``, and ``BAG_CONVERT[BAG_KINDS[msgtype]]`` to turn a
  deserialized message into a common.messages dataclass."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from common.config import strip_frame
from common.geometry import Pose2D, Quaternion, Transform, Vector3
from common.messages import CameraInfo, DepthImage, Header, LaserScan, Odometry, TFMessage, TransformStamped, Twist

T = TypeVar("T")

CARMEN_MAX_RANGE = 80.0  # SICK "no return" values are 81.83 / 81.91
CARMEN_LASER = ("FLASER", "ROBOTLASER1")


class LogError(ValueError):
    """A log file that cannot be read: the message names the file (and line) and what is wrong."""


@dataclass(frozen=True)
class ScanRecord:
    stamp: float  # s (CARMEN ipc_timestamp / bag header stamp)
    odom: Pose2D  # odometry pose of the base at ``stamp``
    scan: LaserScan
    laser: Pose2D | None = None  # base frame <- the scan's frame, when the log says (else: the base's own)


# -- CARMEN --------------------------------------------------------------------------------------

def flaser_scan(ranges: np.ndarray, stamp: float, frame_id: str = "laser") -> LaserScan:
    """FLASER beam geometry: angle_i = -pi/2 + i*step, step pi/180 (180/181 beams) or pi/360."""
    n = len(ranges)
    step = math.pi / 180.0 if n <= 181 else math.pi / 360.0
    return LaserScan(Header(stamp, frame_id), -math.pi / 2, -math.pi / 2 + (n - 1) * step, step, 0.0, 0.0,
                     0.0, CARMEN_MAX_RANGE, np.asarray(ranges, np.float32))


def carmen_laser(t: list[str]) -> ScanRecord:
    """One FLASER (odometry = its odom_x/y/theta) or ROBOTLASER1 (robot pose) line, split into words."""
    if t[0] == "FLASER":
        n = int(t[1])
        r = np.array(t[2:2 + n], float)
        o = t[2 + n:2 + n + 6]
        stamp = float(t[2 + n + 6])
        return ScanRecord(stamp, Pose2D(float(o[3]), float(o[4]), float(o[5])), flaser_scan(r, stamp))
    # ROBOTLASER1
    start, fov, res, max_r = map(float, t[2:6])
    n = int(t[8])
    r = np.array(t[9:9 + n], np.float32)
    k = 9 + n
    m = int(t[k])
    k += 1 + m
    robot = Pose2D(*map(float, t[k + 3:k + 6]))
    stamp = float(t[k + 11])
    scan = LaserScan(Header(stamp, "laser"), start, start + (n - 1) * res, res, 0.0, 0.0, 0.0,
                     max_r, r)
    return ScanRecord(stamp, robot, scan)


def carmen_odom(t: list[str]) -> Odometry:
    """ODOM x y theta tv rv accel ipc_timestamp ipc_hostname logger_timestamp"""
    x, y, th, tv, rv = map(float, t[1:6])
    stamp = float(t[7])
    if not all(map(math.isfinite, (x, y, th, tv, rv, stamp))):
        raise ValueError("not a finite number")
    return Odometry(Header(stamp, "odom"), "base_link", Pose2D(x, y, th).to_transform(), Twist.planar(tv, rv))


def read_carmen_lines(path: str | Path, parsers: Mapping[str, Callable[[list[str]], T]]) -> Iterator[T]:
    """``parsers[word](words)`` for each line whose first word is a key of ``parsers``, in file order.

    A line that does not parse raises LogError naming ``file:line``; so does a file that is not UTF-8 text."""
    try:
        with open(path, encoding="utf-8") as f:
            for lineno, line in enumerate(f, 1):
                t = line.split()
                parse = parsers.get(t[0]) if t else None
                if parse is None:
                    continue
                try:
                    rec = parse(t)
                except (IndexError, TypeError, ValueError) as e:
                    raise LogError(f"{path}:{lineno}: malformed {t[0]} line ({e or 'too short'})") from None
                yield rec
    except UnicodeDecodeError:
        raise LogError(f"{path}: not a CARMEN text log (not UTF-8 text; a ROS1 bag must end in .bag)") from None


def carmen_span(path: str | Path) -> tuple[float | None, float | None, int, int]:
    """First / last ipc_timestamp and the numbers of laser and ODOM lines, in one fast pass.

    A line whose stamp does not parse is counted but not checked here (``read_carmen_lines`` names it).
    LogError: not UTF-8 text, unreadable, or no FLASER, ROBOTLASER1 or ODOM line at all."""
    start = end = None
    lasers = odoms = 0
    try:
        with open(path, encoding="utf-8") as f:
            for line in f:
                if line.startswith((*CARMEN_LASER, "ODOM")):
                    if line.startswith("ODOM"):
                        odoms += 1
                    else:
                        lasers += 1
                    try:
                        t = float(line.split()[-3])
                    except (IndexError, ValueError):
                        continue
                    start = t if start is None else min(start, t)
                    end = t if end is None else max(end, t)
    except UnicodeDecodeError:
        raise LogError(f"{path}: not a CARMEN text log (not UTF-8 text)") from None
    except OSError as e:
        raise LogError(f"{path}: cannot read: {e.strerror or e}") from None
    if not lasers and not odoms:
        raise LogError(f"{path}: no FLASER, ROBOTLASER1 or ODOM lines (not a CARMEN log?)")
    return start, end, lasers, odoms


# -- ROS1 bags -----------------------------------------------------------------------------------

BAG_KINDS = {"sensor_msgs/msg/LaserScan": "scan", "nav_msgs/msg/Odometry": "odom",
             "tf2_msgs/msg/TFMessage": "tf", "tf/msg/tfMessage": "tf", "sensor_msgs/msg/Image": "image",
             "sensor_msgs/msg/CameraInfo": "info"}


def bag_reader(path: str | Path) -> Any:
    """A rosbags ROS1 ``Reader`` of ``path``, not yet opened (LogError when rosbags is not installed)."""
    try:
        from rosbags.rosbag1 import Reader
    except ImportError:
        raise LogError(f"{path}: reading ROS1 bags needs the 'rosbags' package (pip install rosbags)") from None
    return Reader(str(path))


def bag_typestore(connections: Iterable[Any]) -> Any:
    """The ROS1 Noetic types, plus the bag's own definitions of the BAG_KINDS types among ``connections``
    that Noetic lacks (tf2_msgs, custom builds)."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    for c in connections:
        if BAG_KINDS.get(c.msgtype) and c.msgtype not in store.fielddefs:
            store.register(get_types_from_msg(c.msgdef.data, c.msgtype))
    return store


def bag_stamp(h: Any) -> float:
    """A ROS header's stamp in seconds."""
    return h.stamp.sec + h.stamp.nanosec * 1e-9


def _header(h: Any) -> Header:
    return Header(bag_stamp(h), strip_frame(h.frame_id))


def _transform(p: Any, q: Any) -> Transform:
    return Transform(Vector3(float(p.x), float(p.y), float(p.z)), Quaternion(float(q.x), float(q.y),
                                                                             float(q.z), float(q.w)))


def bag_scan(m: Any) -> LaserScan:
    """sensor_msgs/LaserScan with the bag's own angle fields; intensities kept when there is one per range."""
    ranges = np.asarray(m.ranges, np.float32)
    inten = np.asarray(m.intensities, np.float32)
    return LaserScan(_header(m.header), float(m.angle_min), float(m.angle_max), float(m.angle_increment),
                     float(m.time_increment), float(m.scan_time), float(m.range_min), float(m.range_max), ranges,
                     inten if len(inten) == len(ranges) else np.zeros(0, np.float32))


def bag_odom(m: Any) -> Odometry:
    tw = m.twist.twist
    return Odometry(_header(m.header), strip_frame(m.child_frame_id),
                    _transform(m.pose.pose.position, m.pose.pose.orientation),
                    Twist(Vector3(float(tw.linear.x), float(tw.linear.y), float(tw.linear.z)),
                          Vector3(float(tw.angular.x), float(tw.angular.y), float(tw.angular.z))))


def bag_tf(m: Any) -> TFMessage:
    return TFMessage(tuple(TransformStamped(_header(ts.header), strip_frame(ts.child_frame_id),
                                            _transform(ts.transform.translation, ts.transform.rotation))
                           for ts in m.transforms))


def bag_depth(m: Any) -> DepthImage | None:
    """32FC1 (metres) or 16UC1 / mono16 (millimetres); any other encoding -> None (not a depth image)."""
    enc = m.encoding.upper()
    kinds = {"32FC1": "f4", "16UC1": "u2", "MONO16": "u2"}
    if enc not in kinds:
        return None
    dt = np.dtype(kinds[enc]).newbyteorder(">" if m.is_bigendian else "<")
    row = m.step // dt.itemsize
    a = np.frombuffer(np.asarray(m.data, np.uint8).tobytes(), dt, count=m.height * row).reshape(m.height, row)
    a = a[:, :m.width].astype(np.float32)
    if dt.kind == "u":
        a /= 1000.0
    return DepthImage(_header(m.header), a)


def bag_camera_info(m: Any) -> CameraInfo:
    k = getattr(m, "K", None)
    k = getattr(m, "k", None) if k is None else k
    return CameraInfo(_header(m.header), int(m.width), int(m.height), float(k[0]), float(k[4]), float(k[2]),
                      float(k[5]))


BAG_CONVERT: dict[str, Callable[[Any], object]] = {"scan": bag_scan, "odom": bag_odom, "tf": bag_tf,
                                                   "image": bag_depth, "info": bag_camera_info}
