"""What SLAM reads from a log: each scan with the odometry pose of the base at its stamp (ScanRecord).

The formats are parsed in ``common.robot_logs``, as `zenav play` reads them: a CARMEN laser line carries its
own odometry; a ROS1 bag's /odom is interpolated at each /scan stamp."""

from __future__ import annotations

import bisect
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from common.geometry import Pose2D, normalize_angle
from common.messages import LaserScan
from common.robot_logs import (
    CARMEN_LASER,
    CARMEN_MAX_RANGE,
    LogError,
    ScanRecord,
    bag_odom,
    bag_reader,
    bag_scan,
    bag_typestore,
    carmen_laser,
    flaser_scan,
    read_carmen_lines,
)

__all__ = ["CARMEN_MAX_RANGE", "LogError", "ScanRecord", "flaser_scan", "read_bag", "read_carmen", "read_log"]


def read_carmen(path: str | Path) -> Iterator[ScanRecord]:
    """FLASER (odometry = the embedded odom_x/y/theta) and ROBOTLASER1 (robot pose) lines."""
    return read_carmen_lines(path, dict.fromkeys(CARMEN_LASER, carmen_laser))


def _interp_pose(ts: list[float], poses: list[Pose2D], t: float) -> Pose2D:
    """Odometry linearly interpolated at ``t`` (clamped at the ends; yaw along the short arc)."""
    i = bisect.bisect_left(ts, t)
    if i <= 0:
        return poses[0]
    if i >= len(ts):
        return poses[-1]
    t0, t1 = ts[i - 1], ts[i]
    a = 0.0 if t1 == t0 else (t - t0) / (t1 - t0)
    p0, p1 = poses[i - 1], poses[i]
    dth = normalize_angle(p1.theta - p0.theta)
    return Pose2D(p0.x + a * (p1.x - p0.x), p0.y + a * (p1.y - p0.y), normalize_angle(p0.theta + a * dth))


def read_bag(path: str | Path, scan_topic: str = "/scan", odom_topic: str = "/odom") -> Iterator[ScanRecord]:
    """ROS1 bag: LaserScan keeps the bag's own angle fields; odom interpolated at each scan stamp."""
    reader = bag_reader(path)
    ots: list[float] = []
    oposes: list[Pose2D] = []
    scans: list[LaserScan] = []
    try:
        with reader:
            conns = [c for c in reader.connections if c.topic in (scan_topic, odom_topic)]
            store = bag_typestore(conns)
            for conn, _, raw in reader.messages(connections=conns):
                msg = store.deserialize_ros1(raw, conn.msgtype)
                if conn.topic == odom_topic:
                    odom = bag_odom(msg)
                    ots.append(odom.header.stamp)
                    oposes.append(odom.pose2d)
                else:
                    scans.append(bag_scan(msg))
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
