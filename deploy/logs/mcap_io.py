"""MCAP files: ``McapLogWriter`` (what ``zenav record`` writes) and ``read_records`` (what ``zenav play`` reads).

Channels: a message with a standard ROS1 type (``deploy.logs.ros1_msgs``) is written with schema encoding
``ros1msg`` (the full ROS1 definition) and message encoding ``ros1``, so Foxglove Studio shows it; every
other type with schema encoding ``zenav-msgpack`` (schema name = our type name, data = its fields) and our
msgpack codec as message encoding, so nothing is lost. Topics are ROS style (``/scan``); channel metadata
``zenav_type`` holds our type name (and ``costmap_layer`` for a Costmap written as an OccupancyGrid).
Times: log_time = the message stamp (see ``LogClock``), publish_time = the receive time.
"""

from __future__ import annotations

import logging
import math
import struct
import threading
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

from deploy.logs import LogRecord
from deploy.logs.ros1_decode import Ros1DecodeError, can_decode, deserialize, ros_type_name
from deploy.logs.ros1_msgs import MD5SUMS, full_definition, serialize

log = logging.getLogger(__name__)

MSGPACK = "zenav-msgpack"
SIM_STAMP_MAX = 1e8  # stamps below are simulated seconds (a wall stamp is > 1.6e9)


class McapReadError(ValueError):
    """A file that is not a readable MCAP file (truncated, corrupt, not MCAP): one clear line."""


def _ns(t: float) -> int:
    return max(0, int(round(t * 1e9))) if math.isfinite(t) else 0


def msg_stamp(msg) -> float:
    """The stamp of a message: its header's, the first transform's of a TFMessage, a Clock's value; else 0."""
    h = getattr(msg, "header", None)
    if h is not None:
        return h.stamp
    if getattr(type(msg), "_msg_name", "") == "TFMessage":
        return max((t.header.stamp for t in msg.transforms), default=0.0)
    if getattr(type(msg), "_msg_name", "") == "Clock":
        return msg.clock
    return 0.0


class LogClock:
    """The log time of a received message: its stamp, unless it has none (0) or the stamp is more than
    ``tolerance`` seconds from the bus clock at reception (a latched map stamped long ago, an agent
    stamping wall time during a simulation): then the bus clock. The bus clock is the last ``clock``
    message when there is one, else the newest simulated stamp when stamps are simulated, else wall time."""

    def __init__(self, tolerance: float = 60.0) -> None:
        self.tolerance = tolerance
        self.clock: float | None = None
        self.sim_latest: float | None = None

    def update_clock(self, t: float) -> None:
        if math.isfinite(t) and (self.clock is None or t > self.clock):
            self.clock = t

    def now(self, recv_wall: float) -> float:
        if self.clock is not None:
            return self.clock
        return self.sim_latest if self.sim_latest is not None else recv_wall

    def log_time(self, stamp: float, recv_wall: float) -> float:
        if stamp > 0 and math.isfinite(stamp):
            if stamp < SIM_STAMP_MAX and self.clock is None:
                self.sim_latest = max(self.sim_latest or 0.0, stamp)
            ref = self.now(recv_wall)
            return stamp if abs(stamp - ref) <= self.tolerance else ref
        return self.now(recv_wall)


@dataclass
class TopicStat:
    messages: int = 0
    bytes: int = 0
    encoding: str = ""


def _msgpack_schema(name: str) -> bytes:
    from common.messages import REGISTRY

    s = REGISTRY[name]
    lines = [f"# zenav {name} version {s.version}: msgpack [\"zenav\", type, version, {{field: value}}]"]
    lines += [f"{k}: {getattr(a, '__name__', None) or str(a)}" for k, a in s.fields.items()]
    return ("\n".join(lines) + "\n").encode()


class McapLogWriter:
    """Write zenav messages to an MCAP file (thread-safe). ``OSError`` when the path cannot be written."""

    def __init__(self, path: str, compression: str = "zstd", chunk_size: int = 4 << 20) -> None:
        from mcap.writer import CompressionType, Writer

        self.path = str(path)
        self._file = open(self.path, "wb")  # noqa: SIM115 - closed in close()
        self._writer = Writer(self._file, chunk_size=chunk_size, compression=CompressionType[compression.upper()])
        self._writer.start(profile="", library="zenav record")
        self._schemas: dict[tuple[str, str], int] = {}
        self._channels: dict[tuple, int] = {}
        self._seq: dict[int, int] = {}
        self._lock = threading.Lock()
        self.stats: dict[str, TopicStat] = {}
        self.closed = False

    def _schema(self, encoding: str, name: str) -> int:
        key = (encoding, name)
        if key not in self._schemas:
            data = full_definition(name).encode() if encoding == "ros1msg" else _msgpack_schema(name)
            self._schemas[key] = self._writer.register_schema(name=name, encoding=encoding, data=data)
        return self._schemas[key]

    def _channel(self, topic: str, msg, ros_type: str | None) -> int:
        name = type(msg)._msg_name
        layer = getattr(msg, "layer", None) if name == "Costmap" else None
        key = (topic, name, layer, ros_type is not None)
        if key not in self._channels:
            meta = {"zenav_type": name, **({"costmap_layer": layer} if layer is not None else {})}
            if ros_type is not None:
                sid, enc = self._schema("ros1msg", ros_type), "ros1"
                meta["md5sum"] = MD5SUMS[ros_type]
            else:
                sid, enc = self._schema(MSGPACK, name), MSGPACK
            self._channels[key] = self._writer.register_channel(
                topic="/" + topic.lstrip("/"), message_encoding=enc, schema_id=sid, metadata=meta)
        return self._channels[key]

    def write(self, topic: str, msg, log_time: float, publish_time: float | None = None,
              payload: bytes | None = None) -> int:
        """Write ``msg`` on ``topic`` (zenav name); ``payload``: its msgpack bytes if at hand. Returns bytes."""
        ros = None
        try:
            ros = serialize(msg)
        except (struct.error, OverflowError, ValueError, TypeError) as e:  # e.g. a negative width
            log.warning("%s: %s not writable as ROS1 (%s): kept in msgpack", topic, type(msg).__name__, e)
        if ros is None and payload is None:
            from common.codec import encode

            payload = encode(msg)
        data = ros[1] if ros is not None else payload
        with self._lock:
            if self.closed:
                return 0
            cid = self._channel(topic, msg, ros[0] if ros is not None else None)
            seq = self._seq[cid] = self._seq.get(cid, -1) + 1
            self._writer.add_message(channel_id=cid, log_time=_ns(log_time), data=data, sequence=seq & 0xFFFFFFFF,
                                     publish_time=_ns(log_time if publish_time is None else publish_time))
            st = self.stats.setdefault(topic, TopicStat(encoding="ros1" if ros is not None else MSGPACK))
            st.messages += 1
            st.bytes += len(data)
        return len(data)

    def close(self) -> None:
        """Write the summary and index and close the file (idempotent)."""
        with self._lock:
            if self.closed:
                return
            self.closed = True
            try:
                self._writer.finish()
            finally:
                self._file.close()


def _is_costmap_topic(topic: str) -> bool:
    """costmap_2d's grids: ``<name>/costmap`` and its layers ``<name>/costmap/<layer>``."""
    parts = topic.split("/")
    return "costmap" in parts[-2:] or parts[-1].endswith("_costmap")


def _decoder(schema, channel):
    """A function bytes -> zenav message for one channel, or None when zenav has no message for it."""
    meta = dict(channel.metadata or {})
    if channel.message_encoding == MSGPACK:
        from common.codec import decode

        return decode
    if channel.message_encoding == "ros1" and schema is not None and can_decode(schema.name):
        as_costmap = ros_type_name(schema.name) == "nav_msgs/OccupancyGrid" and (
            meta.get("zenav_type") == "Costmap"
            or ("zenav_type" not in meta and _is_costmap_topic(channel.topic.strip("/"))))
        parts = channel.topic.strip("/").split("/")
        layer = meta.get("costmap_layer", parts[-1] if len(parts) > 1 and parts[-2] == "costmap" else "")
        if as_costmap:
            import dataclasses

            return lambda data: dataclasses.replace(deserialize(schema.name, data, costmap=True), layer=layer)
        return lambda data: deserialize(schema.name, data)
    return None


def _open(path):
    """(file, reader) of a complete MCAP file, checked up to its summary; ``McapReadError`` otherwise."""
    from mcap.exceptions import McapError
    from mcap.reader import make_reader

    try:
        f = open(path, "rb")  # noqa: SIM115 - the caller closes it
    except OSError as e:
        raise McapReadError(f"{path}: cannot read: {e.strerror or e}") from None
    try:
        head = f.read(8)
        if head != b"\x89MCAP0\r\n":
            raise McapReadError(f"{path}: not an MCAP file ({'empty' if not head else 'bad magic'})")
        f.seek(0)
        reader = make_reader(f, validate_crcs=True)
        reader.get_summary()  # a truncated file has no footer: fail here, before any message
        return f, reader
    except BaseException as e:
        f.close()
        if isinstance(e, (McapError, struct.error, ValueError, OSError, EOFError)) and not isinstance(
                e, McapReadError):
            why = str(e) or type(e).__name__
            raise McapReadError(f"{path}: truncated or corrupt MCAP file, no valid footer / summary ({why}); "
                                "was the recording killed? `mcap recover` can repair it") from None
        raise


def read_info(path) -> tuple[float | None, float | None, dict[str, int]]:
    """(first log time, last log time, messages per zenav topic) from the summary; ``McapReadError``."""
    f, reader = _open(path)
    with f:
        summary = reader.get_summary()
    st = summary.statistics if summary is not None else None
    if st is None or not st.message_count:
        return None, None, {}
    counts = {summary.channels[c].topic.lstrip("/"): n for c, n in st.channel_message_counts.items()
              if c in summary.channels}
    return st.message_start_time * 1e-9, st.message_end_time * 1e-9, counts


def read_records(path) -> Iterator[LogRecord]:
    """Every message of an MCAP file that zenav has a message type for, in log-time order.

    Channels zenav cannot map (other encodings, other ROS types, an image that is no depth image) are
    skipped with one warning each; a message that does not decode is skipped with a warning. A file that
    is not a complete MCAP file raises ``McapReadError`` (one line, with the path) at once, corrupt data
    further in while iterating."""
    f, reader = _open(path)
    return _records(path, f, reader)


def _records(path, f, reader) -> Iterator[LogRecord]:
    from common.codec import DecodeError

    with f:
        it = reader.iter_messages(log_time_order=True)
        decoders: dict[int, Callable[[bytes], Any] | None] = {}
        warned: set = set()
        while True:
            try:
                schema, channel, message = next(it)
            except StopIteration:
                return
            except Exception as e:  # noqa: BLE001 - CRC, decompression, record errors: one line
                raise McapReadError(f"{path}: corrupt MCAP data ({str(e) or type(e).__name__})") from None
            if channel.id not in decoders:
                decoders[channel.id] = _decoder(schema, channel)
                if decoders[channel.id] is None:
                    log.warning("%s: skipping %s (%s, %s): no zenav message for it", path, channel.topic,
                                schema.name if schema else "no schema", channel.message_encoding)
            fn = decoders[channel.id]
            if fn is None:
                continue
            try:
                msg = fn(message.data)
            except (Ros1DecodeError, DecodeError) as e:
                if channel.id not in warned:
                    warned.add(channel.id)
                    log.warning("%s: %s: undecodable message skipped (%s)", path, channel.topic, e)
                continue
            yield LogRecord(message.log_time * 1e-9, channel.topic.lstrip("/"), msg)
