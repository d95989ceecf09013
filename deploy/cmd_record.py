"""``zenav record OUT.mcap``: record a robot's topics into an MCAP file (like ``rosbag record``)."""

from __future__ import annotations

import argparse
import logging
import signal
import sys
import threading
import time

from common.argtypes import nonneg, positive
from common.live_keys import LiveKey, live_key
from deploy import close_quietly, one_robot, open_session

log = logging.getLogger(__name__)

DEFAULT_TOPICS = (
    "scan", "odom", "tf", "tf_static", "map", "cmd_vel", "move_base/global_plan", "move_base/local_plan",
    "move_base/current_goal", "move_base_simple/goal", "move_base/goal", "move_base/status", "amcl_pose",
    "global_costmap/costmap", "local_costmap/costmap", "local_costmap/footprint",
)
DEFAULT_RATES = {"Costmap": 2.0}
MAX_QUEUED_BYTES = 512 << 20  # the writer is behind by this much: drop (and count) new messages

DESCRIPTION = f"""\
Record topics of one robot into OUT.mcap (open it in Foxglove Studio, or play it with `zenav play`).
Messages with a standard ROS1 type are written as ROS1 (schema encoding ros1msg, message encoding
ros1): LaserScan, Odometry, tf / tf_static (tf2_msgs/TFMessage), OccupancyGrid, costmaps (as
nav_msgs/OccupancyGrid, costmap_2d's cost table), Path, DepthImage (sensor_msgs/Image 32FC1), CameraInfo,
Twist, PoseStamped, Clock; every other type in zenav's msgpack encoding, so nothing is lost. Topic names
in the file are ROS style (/scan). Log time = the message stamp (the bus clock when a message has none
or a stale one), publish time = the receive time. Latched topics (map, tf_static) are fetched from
their publishers at once. A progress line goes to stderr; Ctrl-C, SIGTERM or --duration end the
recording with a complete, indexed file.

default topics: {", ".join(DEFAULT_TOPICS)}
default rates: Costmap=2 (Hz, per topic; --rate Costmap=0 records every costmap)

examples:
  zenav record run.mcap --robot pioneer1
  zenav record run.mcap --topics scan,odom,tf,tf_static --duration 60
  zenav record all.mcap --all --rate camera/depth/image=5
"""


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser("record", help="record topics into an MCAP file (ROS1 types for Foxglove)",
                              description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("out", metavar="OUT.mcap", help="file to write (replaced if it exists)")
    which = p.add_mutually_exclusive_group()
    which.add_argument("--topics", action="append", metavar="T1,T2", help="topics to record (repeatable or "
                       "comma list; default: the navigation set below)")
    which.add_argument("--all", action="store_true", help="every topic of the robot, as `zenav topic list` sees")
    p.add_argument("--duration", type=positive, default=None, metavar="S", help="stop after S seconds")
    p.add_argument("--rate", action="append", default=[], metavar="NAME=HZ",
                   help="max recording rate of a topic or message type (0 = every message; repeatable or comma "
                        "list); the newest message of a throttled topic is always written")
    p.add_argument("--compression", choices=("zstd", "lz4", "none"), default="zstd", help="chunk compression")
    p.add_argument("--progress", type=nonneg, default=5.0, metavar="S",
                   help="progress line on stderr every S seconds (0 = none)")
    p.set_defaults(func=run)
    return p


class Recorder:
    """Zenoh subscriptions -> a queue -> one writer thread (decode, log time, throttle, write)."""

    def __init__(self, session, robot: str, writer, topics: list[str] | None, rates: dict[str, float]) -> None:
        import queue

        from deploy.logs.mcap_io import LogClock
        from deploy.monitor.pacing import Throttle

        self.session, self.robot, self.writer = session, robot, writer
        self.topics = None if topics is None else set(topics)
        self.prefix = f"zenav/{robot}/"
        self.clock = LogClock()
        self.throttle = Throttle()
        self.throttle.rates = dict(rates)
        self.q: queue.Queue = queue.Queue()
        self.queued_bytes = 0
        self.dropped = self.malformed = 0
        self._lock = threading.Lock()
        self._queried: set[str] = set()
        self._last_hash: dict[str, int] = {}  # topic -> hash of its last payload
        self._latched: dict[str, set[int]] = {}  # topic -> hashes of the latched replies recorded
        self._handles: list = []
        self._closing = False
        self._thread = threading.Thread(target=self._loop, name="record-writer", daemon=True)

    def start(self) -> None:
        import zenoh

        # before any declaration: the liveliness history is delivered at once, on Zenoh's threads, and a
        # publisher token handled before this line was lost for good (its latched map never fetched)
        self._zenoh = zenoh
        self._thread.start()
        keys = [f"{self.prefix}**"] if self.topics is None else [self.prefix + t for t in sorted(self.topics)]
        if self.topics is not None and "clock" not in self.topics:
            keys.append(self.prefix + "clock")  # the time base of simulated runs, not recorded
        for k in keys:
            self._handles.append(self.session.declare_subscriber(k, lambda s: self._on_sample(s, False)))
        self._handles.append(self.session.liveliness().declare_subscriber(
            live_key(self.robot, "latched", "**"), self._on_publisher, history=True))

    def _on_publisher(self, sample) -> None:
        """A publisher appeared: fetch its latched message (a no-op for unlatched topics)."""
        zenoh = self._zenoh
        k = LiveKey.parse(sample.key_expr)
        if sample.kind != zenoh.SampleKind.PUT or k is None or not k.topic or not self._wanted(k.topic):
            return
        with self._lock:
            if str(sample.key_expr) in self._queried:
                return
            self._queried.add(str(sample.key_expr))
        from common.bus_topics import fetch_latched

        fetch_latched(self.session, self.prefix + k.topic, lambda s: self._on_sample(s, True), retry=True,
                      closed=lambda: self._closing, expect=k.node)

    def _wanted(self, topic: str) -> bool:
        return not topic.startswith("srv/") and (self.topics is None or topic in self.topics)

    def _on_sample(self, sample, reply: bool) -> None:
        key = str(sample.key_expr)
        topic = key[len(self.prefix):]
        record = self._wanted(topic)
        if not record and topic != "clock":
            return
        data = sample.payload.to_bytes()
        with self._lock:
            if self.queued_bytes > MAX_QUEUED_BYTES:
                self.dropped += 1
                return
            self.queued_bytes += len(data)
        self.q.put((topic, data, time.time(), reply, record))

    def _loop(self) -> None:
        import queue

        while True:
            try:
                item = self.q.get(timeout=0.1)
            except queue.Empty:
                item = None
            if item is False:  # stop
                break
            if item is not None:
                with self._lock:
                    self.queued_bytes -= len(item[1])
                try:
                    self._handle(*item)
                except Exception as e:  # noqa: BLE001 - one bad message must not end the recording
                    log.warning("could not record a message on %s: %s", item[0], e)
            for _, pending in self.throttle.due():
                self.writer.write(*pending)
        for _, pending in self.throttle.due(flush_all=True):
            self.writer.write(*pending)

    def _handle(self, topic: str, data: bytes, recv: float, reply: bool, record: bool) -> None:
        from common.codec import DecodeError, decode
        from deploy.logs.mcap_io import msg_stamp

        h = hash(data)  # a latched message reaches us by the subscription and by one query per publisher
        seen = self._latched.setdefault(topic, set()) if reply else self._latched.get(topic, ())
        if h in seen or (reply and self._last_hash.get(topic) == h):
            return
        if reply:
            seen.add(h)
        self._last_hash[topic] = h
        try:
            msg = decode(data)
        except DecodeError as e:
            self.malformed += 1
            log.warning("malformed payload on %s: %s", topic, e)
            return
        name = type(msg)._msg_name
        if name == "Clock":
            self.clock.update_clock(msg.clock)
        if not record:
            return
        item = (topic, msg, self.clock.log_time(msg_stamp(msg), recv), recv, data)
        entity = topic + "|" + getattr(msg, "layer", "") if name == "Costmap" else topic
        if self.throttle.offer(entity, self.throttle.period(topic, name), item):
            self.writer.write(*item)

    def _fetch_missing_latched(self, timeout: float = 3.0) -> None:
        """Before closing: ask once more, and wait for, every topic whose publisher was seen but of which
        nothing was recorded — a latched map whose first query found no route yet (a short recording on
        a busy machine) is then still in the file. A topic nobody latches is answered at once (no one)."""
        zenoh = self._zenoh
        with self._lock:
            topics = {k.split("/", 4)[4] for k in self._queried}
        missing = sorted(t for t in topics if t not in self._last_hash)
        if not missing:
            return
        left = [len(missing)]
        done = threading.Event()

        def finished() -> None:
            with self._lock:
                left[0] -= 1
                if left[0] == 0:
                    done.set()
        for t in missing:
            try:
                self.session.get(self.prefix + t, zenoh.handlers.Callback(lambda r: r.ok is not None and
                                                                          self._on_sample(r.ok, True), finished),
                                 target=zenoh.QueryTarget.ALL, consolidation=zenoh.ConsolidationMode.NONE,
                                 timeout=timeout)
            except zenoh.ZError:
                finished()
        done.wait(timeout + 1.0)

    def close(self) -> None:
        self._fetch_missing_latched()
        self._closing = True  # no more latched retries
        close_quietly(*self._handles)
        self.q.put(False)
        self._thread.join(timeout=60)
        self.writer.close()


def _progress(rec: Recorder, elapsed: float) -> str:
    stats = sorted(rec.writer.stats.items())
    n = sum(s.messages for _, s in stats)
    mb = sum(s.bytes for _, s in stats) / 1e6
    per = " ".join(f"{t}={s.messages}/{s.bytes / 1e6:.1f}MB" for t, s in stats)
    extra = f" dropped={rec.dropped}" if rec.dropped else ""
    return f"zenav record: {elapsed:.0f} s {n} msgs {mb:.1f} MB{extra} | {per or 'nothing yet'}"


def _rates(items: list[str]) -> dict[str, float]:
    """DEFAULT_RATES updated by --rate NAME=HZ; ValueError (one line, exit 2) for a bad one."""
    import math

    from deploy.monitor.pacing import parse_rates

    rates = parse_rates(items)
    bad = [f"{k}={v}" for k, v in rates.items() if not math.isfinite(v)]
    if bad:
        raise ValueError(f"--rate {', '.join(bad)}: HZ must be a finite number >= 0")
    return {**DEFAULT_RATES, **rates}


def run(args) -> int:
    from deploy.logs.mcap_io import McapLogWriter

    rates = _rates(args.rate)
    topics = None if args.all else [t.strip().strip("/") for v in (args.topics or [",".join(DEFAULT_TOPICS)])
                                    for t in v.split(",") if t.strip().strip("/")]
    if topics is not None and not topics:
        print("zenav record: --topics names no topic", file=sys.stderr)
        return 2
    robot = one_robot(args)
    from common.bus import topic_key

    for t in topics or ():
        topic_key(robot, t)  # ValueError (one line, exit 2) for a bad name
    try:
        writer = McapLogWriter(args.out, compression=args.compression)
    except OSError as e:
        print(f"zenav record: cannot write {args.out}: {e.strerror or e}", file=sys.stderr)
        return 2
    stop = threading.Event()
    old = {s: signal.signal(s, lambda *_: stop.set()) for s in (signal.SIGINT, signal.SIGTERM)}
    session = rec = None
    t0 = time.monotonic()
    try:
        session = open_session()
        rec = Recorder(session, robot, writer, topics, rates)
        rec.start()
        what = "every topic" if topics is None else f"{len(topics)} topics"
        print(f"zenav record: recording {what} of robot '{robot}' into {args.out} "
              f"({'until Ctrl-C' if args.duration is None else f'{args.duration:g} s'})", file=sys.stderr, flush=True)
        t0 = time.monotonic()
        next_line = t0 + args.progress
        while not stop.is_set():
            now = time.monotonic()
            if args.duration is not None and now - t0 >= args.duration:
                break
            if args.progress and now >= next_line:
                print(_progress(rec, now - t0), file=sys.stderr, flush=True)
                next_line = now + args.progress
            stop.wait(0.1)
    finally:
        if rec is not None:
            rec.close()
        writer.close()
        close_quietly(session)
        for s, h in old.items():
            signal.signal(s, h)
    _summary(rec, args.out, topics, time.monotonic() - t0)
    return 0


def _summary(rec: Recorder | None, out: str, topics: list[str] | None, elapsed: float) -> None:
    if rec is None:
        return
    print(_progress(rec, elapsed).replace("zenav record:", f"zenav record: wrote {out}:", 1), file=sys.stderr)
    if rec.malformed:
        print(f"zenav record: {rec.malformed} malformed payload(s) skipped", file=sys.stderr)
    silent = [t for t in topics or () if t not in rec.writer.stats]
    if silent:
        print(f"zenav record: nothing received on {', '.join(silent)}", file=sys.stderr)
