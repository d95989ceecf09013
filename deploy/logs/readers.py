"""Log readers for `zenav play`: ROS1 bags, CARMEN logs and MCAP files -> LogRecords in log-time order.

The bag and CARMEN formats are parsed in ``common.robot_logs`` (as for ``zenav slam run``); this module turns
their messages into played topics, TF and a ``LogInfo``.

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

from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from common.config import strip_frame
from common.geometry import Pose2D
from common.messages import Header, Odometry, TFMessage, TransformStamped
from common.robot_logs import (
    BAG_CONVERT,
    BAG_KINDS,
    CARMEN_LASER,
    LogError,
    bag_reader,
    bag_typestore,
    carmen_laser,
    carmen_odom,
    carmen_span,
    read_carmen_lines,
)
from deploy.logs import LogRecord

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

def _open_carmen(path: Path, laser_pose) -> tuple[Iterator[LogRecord], LogInfo]:
    start, end, lasers, odoms = carmen_span(path)
    counts = {"scan": lasers, "odom": odoms, "tf": lasers, "tf_static": 1}
    return _carmen_records(path, laser_pose), LogInfo(str(path), "carmen", start, end, counts)


def _carmen_records(path: Path, laser_pose) -> Iterator[LogRecord]:
    first = True
    parsers = {**dict.fromkeys(CARMEN_LASER, _carmen_laser), "ODOM": _carmen_odom}
    for recs in read_carmen_lines(path, parsers):
        if first:
            first = False
            yield static_laser(recs[0].stamp, "laser", laser_pose)
        yield from recs


def _carmen_laser(t: list[str]) -> list[LogRecord]:
    rec = carmen_laser(t)
    tf = TransformStamped(Header(rec.stamp, "odom"), "base_link", rec.odom.to_transform())
    return [LogRecord(rec.stamp, "tf", TFMessage((tf,))), LogRecord(rec.stamp, "scan", rec.scan)]


def _carmen_odom(t: list[str]) -> list[LogRecord]:
    msg = carmen_odom(t)
    return [LogRecord(msg.header.stamp, "odom", msg)]


# -- ROS1 bags -----------------------------------------------------------------------------------

def _open_bag(path: Path, laser_pose) -> tuple[Iterator[LogRecord], LogInfo]:
    reader = bag_reader(path)
    try:
        reader.open()
        store = bag_typestore(reader.connections)  # tf2_msgs and custom types: from the bag's own definitions
    except Exception as e:  # noqa: BLE001 - rosbags raises many types on a damaged file; one line names it
        raise LogError(f"{path}: not a readable ROS1 bag ({type(e).__name__}: {e})") from None
    info = LogInfo(str(path), "bag", reader.start_time * 1e-9 if reader.message_count else None,
                   reader.end_time * 1e-9 if reader.message_count else None)
    played = []
    for c in reader.connections:
        kind = BAG_KINDS.get(c.msgtype)
        if kind is None:
            info.skipped[c.topic] = f"type {c.msgtype} not played"
            continue
        played.append(c)
        topic = c.topic.strip("/")
        info.counts[topic] = info.counts.get(topic, 0) + c.msgcount
    topics = {c.topic.strip("/") for c in played}
    if not topics & {"scan", "odom", "tf"} and not any(BAG_KINDS[c.msgtype] in ("scan", "image") for c in played):
        reader.close()
        raise LogError(f"{path}: no LaserScan, Odometry, TF or depth image messages to play")
    return _bag_records(path, reader, store, played, laser_pose, "tf" in topics), info


def _bag_records(path, reader, store, conns, laser_pose, has_tf: bool) -> Iterator[LogRecord]:
    static_children: set[str] = set()
    first = True
    try:
        try:
            scan_conns = [c for c in conns if BAG_KINDS[c.msgtype] == "scan"]
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
                kind, topic = BAG_KINDS[conn.msgtype], conn.topic.strip("/")
                if first and scan_conns and (laser_pose is not None or laser not in static_children):
                    yield static_laser(stamp, laser, laser_pose)
                first = False
                msg = BAG_CONVERT[kind](store.deserialize_ros1(raw, conn.msgtype))
                if msg is None:
                    continue
                if topic == "tf_static" and laser_pose is not None:
                    assert isinstance(msg, TFMessage)  # a bag's tf_static holds TF messages
                    msg = TFMessage(tuple(t for t in msg.transforms if t.child_frame_id != laser))
                    if not msg.transforms:
                        continue
                yield LogRecord(stamp, topic, msg)
                if kind == "odom" and not has_tf:
                    assert isinstance(msg, Odometry)  # BAG_CONVERT["odom"]
                    tf = TransformStamped(msg.header, msg.child_frame_id, msg.pose)
                    yield LogRecord(stamp, "tf", TFMessage((tf,)))
        finally:
            reader.close()
    except LogError:
        raise
    except Exception as e:  # noqa: BLE001 - a damaged chunk in the middle of the bag
        raise LogError(f"{path}: damaged ROS1 bag ({type(e).__name__}: {e})") from None
