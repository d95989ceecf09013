"""The recorder behind `zenav record`: a robot's topics from the bus into an MCAP file.

Zenoh subscriptions (and latched fetches, asked of each latched publisher as its token appears) feed one
queue; one writer thread decodes, stamps (log time = the message stamp, the bus clock when it has none),
throttles per topic and writes. The queue is bounded in bytes: a writer behind by ``MAX_QUEUED_BYTES``
drops new messages, counted. Messages lost before they reached the recorder (a stream publisher drops what
its link to a starved recorder cannot take, by design) are counted from the publishers' sequence numbers
(``lost``). The command module (deploy/cli/record.py) parses options and prints.
"""

from __future__ import annotations

import logging
import threading
import time

from common.bus import close_quietly
from common.live_keys import LiveKey, live_key
from common.route_watch import sequence_number

log = logging.getLogger(__name__)

MAX_QUEUED_BYTES = 512 << 20  # the writer is behind by this much: drop (and count) new messages


class Gaps:
    """Numbered messages that never came, per (topic, publisher entity): a sequence number more than one past
    the last one seen counts the ones in between. The first message of a publisher counts nothing (what it
    sent before the recorder listened is not a loss); a number at or below the last (a repeat) neither."""

    def __init__(self) -> None:
        self.last: dict[tuple[str, str], int] = {}
        self.lost: dict[str, int] = {}  # topic -> messages lost on the way

    def add(self, topic: str, sn: tuple[str, int] | None) -> None:
        if sn is None:
            return
        key = (topic, sn[0])
        last = self.last.get(key)
        if last is None or sn[1] > last:
            self.last[key] = sn[1]
        if last is not None and sn[1] > last + 1:
            self.lost[topic] = self.lost.get(topic, 0) + sn[1] - last - 1

    def total(self) -> int:
        return sum(self.lost.values())


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
        self.gaps = Gaps()
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
        from common.latched_fetch import fetch_latched

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
            if record and not reply:
                self.gaps.add(topic, sequence_number(sample))
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
            assert isinstance(seen, set)  # the setdefault above
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

        def on_reply(r) -> None:
            if r.ok is not None:
                self._on_sample(r.ok, True)
        for t in missing:
            try:
                self.session.get(self.prefix + t, zenoh.handlers.Callback(on_reply, finished),
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
