"""What SLAM reads from a log: each scan with the odometry pose of the base at its stamp (ScanRecord).

The formats are parsed in ``common.robot_logs``, as `zenav play` reads them: a CARMEN laser line carries its
own odometry; a ROS1 bag's /odom is interpolated at each /scan stamp. A recording's decoded messages (what
`zenav record` writes, decoded where the format lives: ``deploy.logs``) become records in ``scan_records``;
``register_reader`` lets that layer add its file suffix to ``read_log`` without this one importing it."""

from __future__ import annotations

import bisect
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

import numpy as np

from common.config import strip_frame
from common.geometry import Pose2D, normalize_angle
from common.messages import LaserScan, Odometry, TFMessage
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

__all__ = ["CARMEN_MAX_RANGE", "LogError", "ScanRecord", "flaser_scan", "read_bag", "read_carmen", "read_log",
           "register_reader", "scan_records"]

# file suffix (lower case, with the dot) -> reader, added by the layer that parses the format
_READERS: dict[str, Callable[[str | Path], Iterator[ScanRecord]]] = {}


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


def scan_records(messages: Iterable[tuple[str, object]], source: str = "log", scan_topic: str = "scan",
                 odom_topic: str = "odom") -> Iterator[ScanRecord]:
    """Records from a recording's messages, ``(topic, message)`` in log order: each LaserScan on
    ``scan_topic`` with the odometry of ``odom_topic`` interpolated at its stamp, and the scan frame's place
    on the base from ``tf_static`` (the base is the odometry's child frame). A scan waits for the first
    odometry at or after its stamp and for its frame's static transform, which a recording started before
    the robot may hold only after the first scans (at the end the last odometry is used). ``LogError`` when
    there is no odometry or the scan's frame is never linked to the base."""
    from common.tf_buffer import TFBuffer

    statics = TFBuffer(cache_time=1.0)
    ots: list[float] = []
    oposes: list[Pose2D] = []
    base = ""
    pending: deque[LaserScan] = deque()
    lasers: dict[str, Pose2D] = {}

    def laser(s: LaserScan, final: bool = False) -> Pose2D | None:
        """The scan frame's place on the base; None while tf_static does not say it (LogError at the end)."""
        frame = strip_frame(s.header.frame_id)
        if frame not in lasers:
            if not frame or frame == base:
                lasers[frame] = Pose2D()
            else:
                try:
                    lasers[frame] = statics.lookup_pose2d(base, frame)
                except Exception as e:  # noqa: BLE001 - the buffer's errors name the frames
                    if final:
                        raise LogError(f"{source}: the scans' frame {frame!r} is not linked to the base "
                                       f"{base!r} by tf_static ({e})") from None
                    return None
        return lasers[frame]

    def ready(final: bool = False) -> Iterator[ScanRecord]:
        while pending and (final or pending[0].header.stamp <= ots[-1]):
            mount = laser(pending[0], final)
            if mount is None:
                return
            s = pending.popleft()
            yield ScanRecord(s.header.stamp, _interp_pose(ots, oposes, s.header.stamp), s, mount)

    for topic, msg in messages:
        if topic == "tf_static" and isinstance(msg, TFMessage):
            statics.set_transforms(msg.transforms, static=True)
            if ots:
                yield from ready()
        elif topic == odom_topic and isinstance(msg, Odometry):
            t = msg.header.stamp
            if ots and t < ots[-1]:
                continue  # out of order: interpolation needs rising stamps
            base = base or strip_frame(msg.child_frame_id) or "base_link"
            ots.append(t)
            oposes.append(msg.pose2d)
            yield from ready()
        elif topic == scan_topic and isinstance(msg, LaserScan):
            pending.append(msg)
    if not ots:
        raise LogError(f"{source}: no {odom_topic} messages (topics: {scan_topic}, {odom_topic}, tf_static expected)")
    yield from ready(final=True)


def register_reader(suffix: str, reader: Callable[[str | Path], Iterator[ScanRecord]]) -> None:
    """``read_log`` reads files ending in ``suffix`` (e.g. ``.mcap``) with ``reader``."""
    _READERS[suffix.lower()] = reader


def read_log(path: str | Path) -> Iterator[ScanRecord]:
    """Dispatch on the file suffix: a registered reader's, ``.bag`` -> ROS1 bag, anything else -> CARMEN text
    log."""
    suffix = Path(path).suffix.lower()
    if suffix in _READERS:
        return _READERS[suffix](path)
    return read_bag(path) if suffix == ".bag" else read_carmen(path)
