"""Log readers: CARMEN (FLASER / ROBOTLASER1) and ROS1 bags (/scan + /odom) -> ScanRecord stream."""

from __future__ import annotations

import bisect
import math
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from common.geometry import Pose2D, normalize_angle
from common.messages import Header, LaserScan

CARMEN_MAX_RANGE = 80.0  # SICK "no return" values are 81.83 / 81.91


@dataclass(frozen=True)
class ScanRecord:
    stamp: float  # s (CARMEN ipc_timestamp / bag header stamp)
    odom: Pose2D  # odometry pose of the base at ``stamp``
    scan: LaserScan


def flaser_scan(ranges: np.ndarray, stamp: float, frame_id: str = "laser") -> LaserScan:
    """FLASER beam geometry: angle_i = -pi/2 + i*step, step pi/180 (180/181 beams) or pi/360."""
    n = len(ranges)
    step = math.pi / 180.0 if n <= 181 else math.pi / 360.0
    return LaserScan(Header(stamp, frame_id), -math.pi / 2, -math.pi / 2 + (n - 1) * step, step, 0.0, 0.0,
                     0.0, CARMEN_MAX_RANGE, np.asarray(ranges, np.float32))


class LogError(ValueError):
    """A log file that cannot be read: the message names the file (and line) and what is wrong."""


def read_carmen(path: str | Path) -> Iterator[ScanRecord]:
    """FLASER (odometry = the embedded odom_x/y/theta) and ROBOTLASER1 (robot pose) lines."""
    try:
        with open(path, encoding="utf-8") as f:
            for lineno, line in enumerate(f, 1):
                t = line.split()
                if not t or t[0] not in ("FLASER", "ROBOTLASER1"):
                    continue
                try:
                    rec = _carmen_record(t)
                except (IndexError, TypeError, ValueError) as e:
                    raise LogError(f"{path}:{lineno}: malformed {t[0]} line ({e or 'too short'})") from None
                yield rec
    except UnicodeDecodeError:
        raise LogError(f"{path}: not a CARMEN text log (not UTF-8 text; a ROS1 bag must end in .bag)") from None


def _carmen_record(t: list[str]) -> ScanRecord:
    """One FLASER or ROBOTLASER1 line, split into tokens."""
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


def _interp_pose(ts: list[float], poses: list[tuple[float, float, float]], t: float) -> Pose2D:
    """Odometry linearly interpolated at ``t`` (clamped at the ends; yaw along the short arc)."""
    i = bisect.bisect_left(ts, t)
    if i <= 0:
        return Pose2D(*poses[0])
    if i >= len(ts):
        return Pose2D(*poses[-1])
    t0, t1 = ts[i - 1], ts[i]
    a = 0.0 if t1 == t0 else (t - t0) / (t1 - t0)
    p0, p1 = poses[i - 1], poses[i]
    dth = normalize_angle(p1[2] - p0[2])
    return Pose2D(p0[0] + a * (p1[0] - p0[0]), p0[1] + a * (p1[1] - p0[1]), normalize_angle(p0[2] + a * dth))


def read_bag(path: str | Path, scan_topic: str = "/scan", odom_topic: str = "/odom") -> Iterator[ScanRecord]:
    """ROS1 bag: LaserScan keeps the bag's own angle fields; odom interpolated at each scan stamp."""
    from rosbags.rosbag1 import Reader
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    ots: list[float] = []
    oposes: list[tuple[float, float, float]] = []
    scans = []
    try:
        with Reader(str(path)) as reader:
            conns = [c for c in reader.connections if c.topic in (scan_topic, odom_topic)]
            for conn, _, raw in reader.messages(connections=conns):
                msg: Any = store.deserialize_ros1(raw, conn.msgtype)
                stamp = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
                if conn.topic == odom_topic:
                    p, q = msg.pose.pose.position, msg.pose.pose.orientation
                    yaw = math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))
                    ots.append(stamp)
                    oposes.append((p.x, p.y, yaw))
                else:
                    scans.append(LaserScan(Header(stamp, msg.header.frame_id), msg.angle_min, msg.angle_max,
                                           msg.angle_increment, msg.time_increment, msg.scan_time,
                                           msg.range_min, msg.range_max, np.asarray(msg.ranges, np.float32)))
    except (OSError, MemoryError):
        raise
    except Exception as e:  # noqa: BLE001 - rosbags raises many types on a damaged file; one line names it
        raise LogError(f"{path}: not a readable ROS1 bag ({type(e).__name__}: {e})") from None
    if not ots:
        raise LogError(f"{path}: no {odom_topic} messages (topics: {scan_topic}, {odom_topic} expected)")
    order = np.argsort(ots, kind="stable")
    ots = [ots[i] for i in order]
    oposes = [oposes[i] for i in order]
    for s in scans:
        yield ScanRecord(s.header.stamp, _interp_pose(ots, oposes, s.header.stamp), s)


def read_log(path: str | Path) -> Iterator[ScanRecord]:
    """Dispatch on the file suffix: ``.bag`` -> ROS1 bag, anything else -> CARMEN text log."""
    return read_bag(path) if str(path).endswith(".bag") else read_carmen(path)
