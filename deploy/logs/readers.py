"""Log readers for `zenav play`: ROS1 bags, CARMEN logs and MCAP files -> LogRecords in log-time order.

``open_log(path, laser_pose=None)`` opens the file at once (a missing or unreadable file raises
``LogError`` before anything is published) and returns ``(records, info)``:

- ``.bag`` (rosbags): sensor_msgs/LaserScan, nav_msgs/Odometry, tf2_msgs/TFMessage (``/tf``,
  ``/tf_static``), sensor_msgs/Image (32FC1 m or 16UC1 mm -> DepthImage) and CameraInfo; topic names
  without the leading '/'; record stamp = the bag's receive time (what ``rosbag play`` clocks). No
  ``/tf`` in the bag: odom -> base_link from every Odometry message.
- ``.clf`` / ``.log`` (CARMEN): FLASER / ROBOTLASER1 -> ``scan`` (frame ``laser``) plus ``tf``
  odom -> base_link at the scan's stamp from the line's own odometry (what ``zenav slam run`` uses);
  ODOM -> ``odom``.
- ``.mcap``: ``deploy.logs.mcap_io.read_records``.

``tf_static`` base_link -> laser: the log's own, or ``laser_pose`` (x, y, yaw) / identity when the log
has none for the scan frame (``laser_pose`` given replaces the log's)."""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from common.config import strip_frame
from common.geometry import Pose2D, Quaternion, Transform, Vector3
from common.messages import (
    CameraInfo,
    DepthImage,
    Header,
    LaserScan,
    Odometry,
    TFMessage,
    TransformStamped,
    Twist,
)
from deploy.logs import LogRecord
from master_side.slam.logs import LogError, _carmen_record

__all__ = ["LogError", "LogInfo", "open_log"]

SUFFIXES = (".bag", ".clf", ".log", ".mcap")


@dataclass
class LogInfo:
    path: str
    kind: str  # "bag" | "carmen" | "mcap"
    start: float | None = None  # first / last record stamp (None: not known before reading)
    end: float | None = None
    counts: dict[str, int] = field(default_factory=dict)  # messages per played topic, when known
    skipped: dict[str, str] = field(default_factory=dict)  # log topic -> why it is not played

    @property
    def duration(self) -> float | None:
        return None if self.start is None or self.end is None else self.end - self.start


def open_log(path: str | Path, laser_pose: tuple[float, float, float] | None = None
             ) -> tuple[Iterator[LogRecord], LogInfo]:
    p = Path(path)
    if not p.is_file():
        raise LogError(f"{path}: no such file" if not p.exists() else f"{path}: not a file")
    suffix = p.suffix.lower()
    if suffix == ".bag":
        return _open_bag(p, laser_pose)
    if suffix in (".clf", ".log"):
        return _open_carmen(p, laser_pose)
    if suffix == ".mcap":
        from deploy.logs.mcap_io import McapReadError, read_records  # imported only when needed

        try:
            return iter(read_records(str(p))), LogInfo(str(p), "mcap")
        except McapReadError as e:  # names the file and what is wrong already
            raise LogError(str(e)) from None
        except (OSError, ValueError) as e:
            raise LogError(f"{path}: not a readable MCAP file ({e})") from None
    raise LogError(f"{path}: unknown log type {suffix or '(no suffix)'!r} (expected {', '.join(SUFFIXES)})")


def static_laser(stamp: float, frame: str, pose: tuple[float, float, float] | None, base: str = "base_link"
                 ) -> LogRecord:
    tr = Pose2D(*(pose or (0.0, 0.0, 0.0))).to_transform()
    return LogRecord(stamp, "tf_static", TFMessage((TransformStamped(Header(stamp, base), frame, tr),)))


# -- CARMEN --------------------------------------------------------------------------------------

def _carmen_span(path: Path) -> tuple[float | None, float | None, dict[str, int]]:
    """First / last ipc_timestamp and line counts (one fast pass; the values are checked while playing)."""
    start = end = None
    counts = {"scan": 0, "odom": 0}
    try:
        with open(path, encoding="utf-8") as f:
            for line in f:
                if line.startswith(("FLASER", "ROBOTLASER1", "ODOM")):
                    topic = "odom" if line.startswith("ODOM") else "scan"
                    counts[topic] += 1
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
    if not counts["scan"] and not counts["odom"]:
        raise LogError(f"{path}: no FLASER, ROBOTLASER1 or ODOM lines (not a CARMEN log?)")
    counts["tf"] = counts["scan"]
    counts["tf_static"] = 1
    return start, end, counts


def _open_carmen(path: Path, laser_pose) -> tuple[Iterator[LogRecord], LogInfo]:
    start, end, counts = _carmen_span(path)
    return _carmen_records(path, laser_pose), LogInfo(str(path), "carmen", start, end, counts)


def _carmen_records(path: Path, laser_pose) -> Iterator[LogRecord]:
    first = True
    with open(path, encoding="utf-8") as f:
        for lineno, line in enumerate(f, 1):
            t = line.split()
            if not t or t[0] not in ("FLASER", "ROBOTLASER1", "ODOM"):
                continue
            try:
                recs = _carmen_odom(t) if t[0] == "ODOM" else _carmen_laser(t)
            except (IndexError, TypeError, ValueError) as e:
                raise LogError(f"{path}:{lineno}: malformed {t[0]} line ({e or 'too short'})") from None
            if first:
                first = False
                yield static_laser(recs[0].stamp, "laser", laser_pose)
            yield from recs


def _carmen_laser(t: list[str]) -> list[LogRecord]:
    rec = _carmen_record(t)
    tf = TransformStamped(Header(rec.stamp, "odom"), "base_link", rec.odom.to_transform())
    return [LogRecord(rec.stamp, "tf", TFMessage((tf,))), LogRecord(rec.stamp, "scan", rec.scan)]


def _carmen_odom(t: list[str]) -> list[LogRecord]:
    """ODOM x y theta tv rv accel ipc_timestamp ipc_hostname logger_timestamp"""
    x, y, th, tv, rv = map(float, t[1:6])
    stamp = float(t[7])
    if not all(map(math.isfinite, (x, y, th, tv, rv, stamp))):
        raise ValueError("not a finite number")
    msg = Odometry(Header(stamp, "odom"), "base_link", Pose2D(x, y, th).to_transform(), Twist.planar(tv, rv))
    return [LogRecord(stamp, "odom", msg)]


# -- ROS1 bags -----------------------------------------------------------------------------------

KINDS = {"sensor_msgs/msg/LaserScan": "scan", "nav_msgs/msg/Odometry": "odom", "tf2_msgs/msg/TFMessage": "tf",
         "tf/msg/tfMessage": "tf", "sensor_msgs/msg/Image": "image", "sensor_msgs/msg/CameraInfo": "info"}


def _stamp(h) -> float:
    return h.stamp.sec + h.stamp.nanosec * 1e-9


def _transform(p, q) -> Transform:
    return Transform(Vector3(float(p.x), float(p.y), float(p.z)), Quaternion(float(q.x), float(q.y),
                                                                             float(q.z), float(q.w)))


def _scan(m) -> LaserScan:
    ranges = np.asarray(m.ranges, np.float32)
    inten = np.asarray(m.intensities, np.float32)
    return LaserScan(Header(_stamp(m.header), strip_frame(m.header.frame_id)), float(m.angle_min),
                     float(m.angle_max), float(m.angle_increment), float(m.time_increment), float(m.scan_time),
                     float(m.range_min), float(m.range_max), ranges, inten if len(inten) == len(ranges) else
                     np.zeros(0, np.float32))


def _odom(m) -> Odometry:
    tw = m.twist.twist
    return Odometry(Header(_stamp(m.header), strip_frame(m.header.frame_id)), strip_frame(m.child_frame_id),
                    _transform(m.pose.pose.position, m.pose.pose.orientation),
                    Twist(Vector3(float(tw.linear.x), float(tw.linear.y), float(tw.linear.z)),
                          Vector3(float(tw.angular.x), float(tw.angular.y), float(tw.angular.z))))


def _tf(m) -> TFMessage:
    return TFMessage(tuple(TransformStamped(Header(_stamp(ts.header), strip_frame(ts.header.frame_id)),
                                            strip_frame(ts.child_frame_id),
                                            _transform(ts.transform.translation, ts.transform.rotation))
                           for ts in m.transforms))


def _depth(m) -> DepthImage | None:
    """32FC1 (metres) or 16UC1 / mono16 (millimetres); any other encoding -> None (not played)."""
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
    return DepthImage(Header(_stamp(m.header), strip_frame(m.header.frame_id)), a)


def _info(m) -> CameraInfo:
    k = getattr(m, "K", None)
    k = getattr(m, "k", None) if k is None else k
    return CameraInfo(Header(_stamp(m.header), strip_frame(m.header.frame_id)), int(m.width), int(m.height),
                      float(k[0]), float(k[4]), float(k[2]), float(k[5]))


CONVERT = {"scan": _scan, "odom": _odom, "tf": _tf, "image": _depth, "info": _info}


def _open_bag(path: Path, laser_pose) -> tuple[Iterator[LogRecord], LogInfo]:
    try:
        from rosbags.rosbag1 import Reader
        from rosbags.typesys import Stores, get_types_from_msg, get_typestore
    except ImportError:
        raise LogError(f"{path}: reading ROS1 bags needs the 'rosbags' package (pip install rosbags)") from None
    store = get_typestore(Stores.ROS1_NOETIC)
    reader = Reader(str(path))
    try:
        reader.open()
        for c in reader.connections:  # tf2_msgs and custom types: from the bag's own definitions
            if KINDS.get(c.msgtype) and c.msgtype not in store.fielddefs:
                store.register(get_types_from_msg(c.msgdef.data, c.msgtype))
    except Exception as e:  # noqa: BLE001 - rosbags raises many types on a damaged file; one line names it
        raise LogError(f"{path}: not a readable ROS1 bag ({type(e).__name__}: {e})") from None
    info = LogInfo(str(path), "bag", reader.start_time * 1e-9 if reader.message_count else None,
                   reader.end_time * 1e-9 if reader.message_count else None)
    played = []
    for c in reader.connections:
        kind = KINDS.get(c.msgtype)
        if kind is None:
            info.skipped[c.topic] = f"type {c.msgtype} not played"
            continue
        played.append(c)
        topic = c.topic.strip("/")
        info.counts[topic] = info.counts.get(topic, 0) + c.msgcount
    topics = {c.topic.strip("/") for c in played}
    if not topics & {"scan", "odom", "tf"} and not any(KINDS[c.msgtype] in ("scan", "image") for c in played):
        reader.close()
        raise LogError(f"{path}: no LaserScan, Odometry, TF or depth image messages to play")
    return _bag_records(path, reader, store, played, laser_pose, "tf" in topics), info


def _bag_records(path, reader, store, conns, laser_pose, has_tf: bool) -> Iterator[LogRecord]:
    static_children: set[str] = set()
    first = True
    try:
        try:
            scan_conns = [c for c in conns if KINDS[c.msgtype] == "scan"]
            for c in conns:
                if c.topic.strip("/") == "tf_static":
                    for _, _, raw in reader.messages(connections=[c]):
                        static_children |= {strip_frame(t.child_frame_id)
                                            for t in store.deserialize_ros1(raw, c.msgtype).transforms}
            laser = "laser"
            for _, _, raw in reader.messages(connections=scan_conns):
                laser = strip_frame(store.deserialize_ros1(raw, scan_conns[0].msgtype).header.frame_id) or laser
                break
            for conn, t_ns, raw in reader.messages(connections=conns):
                stamp = t_ns * 1e-9
                kind, topic = KINDS[conn.msgtype], conn.topic.strip("/")
                if first and scan_conns and (laser_pose is not None or laser not in static_children):
                    yield static_laser(stamp, laser, laser_pose)
                first = False
                msg = CONVERT[kind](store.deserialize_ros1(raw, conn.msgtype))
                if msg is None:
                    continue
                if topic == "tf_static" and laser_pose is not None:
                    msg = TFMessage(tuple(t for t in msg.transforms if t.child_frame_id != laser))
                    if not msg.transforms:
                        continue
                yield LogRecord(stamp, topic, msg)
                if kind == "odom" and not has_tf:
                    tf = TransformStamped(msg.header, msg.child_frame_id, msg.pose)
                    yield LogRecord(stamp, "tf", TFMessage((tf,)))
        finally:
            reader.close()
    except LogError:
        raise
    except Exception as e:  # noqa: BLE001 - a damaged chunk in the middle of the bag
        raise LogError(f"{path}: damaged ROS1 bag ({type(e).__name__}: {e})") from None
