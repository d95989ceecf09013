"""Topics of the zenav bus: ``Publisher`` (optionally latched: late subscribers get the last message)
and ``Subscription`` (keep-latest or queued, optional callback on its own thread, malformed payloads
counted and dropped). Created through ``common.bus.Node``."""

from __future__ import annotations

import collections
import contextlib
import logging
import queue
import threading
import time
import traceback
from typing import TYPE_CHECKING, Any, Callable

import zenoh

from common.bus_sender import LatestSender
from common.codec import DecodeError, decode, encode
from common.latched_fetch import NOTHING_YET, fetch_latched, topic_key
from common.live_keys import LiveKey, live_key
from common.log_util import RateLimitedLog
from common.msg_check import problem
from common.route_watch import Stream, count_source, sequence_number

if TYPE_CHECKING:
    from common.bus import Node

log = logging.getLogger("zenav.bus")


class Publisher:
    def __init__(self, node: Node, topic: str, latched: bool, reliable: bool, background: bool = False) -> None:
        self.topic, self.key, self._node, self.latched = topic, topic_key(node.robot, topic), node, latched
        cc = zenoh.CongestionControl.BLOCK if reliable else zenoh.CongestionControl.DROP
        self._pub = node.session.declare_publisher(self.key, congestion_control=cc, express=True)
        self._attachment = node.name.encode()
        self._attachment_z = zenoh.ZBytes(self._attachment)  # built once, not per message
        # each put carries Zenoh's source info (this publisher's id, a sequence number from 1): a reader can tell
        # a pause (no number skipped) from messages lost (common.route_watch). Readers that do not look at it
        # (an older zenav) are unaffected: the attachment stays the publisher's name.
        self._id = self._pub.id
        self.sn = 0
        self._last: bytes | None = None
        self._queryable: Any = None
        self._latched_token: Any = None
        self.count = 0
        if latched:  # answers queries for the last message; its own token tells subscribers to ask it
            self._queryable = node.queryables.declare(self.key, self._on_query, complete=False)
            self._latched_token = node._declare_token("latched", topic)
        self._token = node._declare_token("pub", topic)
        # background: put from a sender thread, never blocking the caller (common/bus_sender.py)
        self._sender = LatestSender(self._put, topic) if background else None

    def _put(self, data: bytes) -> None:
        with contextlib.suppress(zenoh.ZError):  # undeclared while the sender thread was putting
            self._put_now(data)

    def _put_now(self, data: bytes) -> None:
        self.sn += 1  # numbered when put, so a message a background sender replaced is no gap
        self._pub.put(data, attachment=self._attachment_z, source_info=zenoh.SourceInfo(self._id, self.sn))

    def _on_query(self, query: zenoh.Query) -> None:
        last = self._last
        if last is not None:
            query.reply(self.key, last, attachment=self._attachment)
        else:
            query.reply_err(f"{NOTHING_YET}{self._node.name}".encode())

    @property
    def matching(self) -> bool:
        """Whether some subscriber is reachable now (Zenoh's matching status): False for a publisher
        whose readers are gone or whose route has not formed (yet) — what a lost link looks like."""
        try:
            # zenoh's stub types matching_status as bool; it is a MatchingStatus
            return bool(self._pub.matching_status.matching)  # type: ignore[attr-defined]
        except zenoh.ZError:  # undeclared
            return False

    def publish(self, msg: Any) -> None:
        data = encode(msg)
        if self.latched:
            self._last = data
        if self._sender is not None:
            self._sender.send(data)
        else:
            self._put_now(data)
        self.count += 1

    def threads(self) -> list[threading.Thread]:
        """Its thread that may be inside Zenoh (the background sender), for the node to join on close."""
        return [self._sender.thread] if self._sender is not None else []

    def close(self) -> None:
        if self._sender is not None:
            self._sender.close()
        for obj in (self._pub, self._queryable, self._latched_token, self._token):
            if obj is not None:
                with contextlib.suppress(zenoh.ZError):
                    obj.undeclare()


class Subscription:
    """Receives one topic. mode='latest' keeps only the newest message, 'queue' keeps up to
    ``queue_size`` (oldest dropped, counted). With a callback, messages are delivered on a
    worker thread of this subscription, so a slow callback never stalls the network; ``inline=True``
    calls it on Zenoh's thread instead (a callback of a few microseconds on a fast stream, as the sim
    clock's: the hand-off to a worker would cost more than the callback)."""

    def __init__(self, node: Node, topic: str, msg_type: type | None, callback: Callable | None,
                 mode: str, queue_size: int, inline: bool = False) -> None:
        if mode not in ("latest", "queue"):
            raise ValueError("mode must be 'latest' or 'queue'")
        self.topic, self.key, self.msg_type = topic, topic_key(node.robot, topic), msg_type
        self._node, self._callback, self.mode = node, callback, mode
        self._cv = threading.Condition()
        self._latest: Any = None
        self._queue: collections.deque = collections.deque(maxlen=queue_size if mode == "queue" else 1)
        self.received = 0  # valid messages
        self.malformed = 0  # payloads that failed to decode (dropped)
        self.invalid = 0  # decoded but unusable: NaN position, zero quaternion, empty map... (dropped)
        self.errors = 0  # messages whose callback raised
        self.dropped = 0  # valid messages overwritten before being consumed
        self.last_receive_time = 0.0  # time.monotonic() of the last valid message
        # per publisher (its name, as the attachment bytes): [messages, last time, smoothed period]
        self.sources: dict[bytes, Stream] = {}  # (common.route_watch)
        self._last_attachment = None  # the publisher's name, as it came (decoded when asked)
        self._waiting = 0  # threads in wait() / wait_first() / get(): notified per message only if any
        self._kick: queue.SimpleQueue = queue.SimpleQueue()  # one token per message for the callback thread
        self._warn = RateLimitedLog()
        self._closed = False
        self._worker = None
        self._inline = inline and callback is not None
        if callback is not None and not self._inline:
            self._worker = threading.Thread(target=self._deliver, daemon=True, name=f"sub:{topic}")
            self._worker.start()
        self._sub = node.session.declare_subscriber(self.key, self._on_sample)
        # Latched topics: ask each latched publisher for its last message when its token is seen (those
        # already there come as the token subscriber's history), asking again until it answers — so
        # neither start order nor a query that found no route loses the message; unlatched publishers
        # are never asked.
        self._pub_watch = node.session.liveliness().declare_subscriber(
            live_key(node.robot, "latched", "*", topic), self._on_publisher, history=True)

    @property
    def closed(self) -> bool:
        return self._closed

    def redeclare(self) -> None:
        """Declare the Zenoh subscriber again (common.route_watch): the old one goes first, so the
        session announces the new one to its peers even if it merges subscribers of one key."""
        with self._cv:
            if self._closed:
                return
            with contextlib.suppress(zenoh.ZError):
                self._sub.undeclare()
            self._sub = self._node.session.declare_subscriber(self.key, self._on_sample)

    def _on_publisher(self, sample: zenoh.Sample) -> None:
        """A latched publisher's token: ask until that publisher answers."""
        if sample.kind == zenoh.SampleKind.PUT and (k := LiveKey.parse(sample.key_expr)) is not None \
                and not self._closed:
            fetch_latched(self._node.session, self.key, self._on_sample, retry=True, closed=lambda: self._closed,
                          expect=k.node)

    def _on_sample(self, sample: zenoh.Sample) -> None:
        self._ingest(sample.payload.to_bytes(), sample.attachment, str(sample.key_expr), sequence_number(sample))

    def _ingest(self, data: bytes, attachment, key: str = "", sn: tuple[str, int] | None = None) -> None:
        try:
            msg = decode(data, self.msg_type)
        except DecodeError as e:
            self.malformed += 1
            sender = attachment.to_bytes().decode(errors="replace") if attachment is not None else "?"
            where = f" (sample key '{key}')" if key and key != self.key else ""
            self._warn(log, f"[{self._node.name}] dropped malformed payload on '{self.topic}' from "
                            f"'{sender}'{where} (#{self.malformed}): {e}")
            return
        why = problem(msg, self._node.clock.now())
        if why:
            self.invalid += 1
            self._warn(log, f"[{self._node.name}] dropped invalid message on '{self.topic}' "
                            f"(#{self.invalid}): {why}")
            return
        with self._cv:
            self._latest = msg
            if len(self._queue) == self._queue.maxlen:
                self.dropped += 1
            self._queue.append(msg)
            now = time.monotonic()
            self.received += 1
            self.last_receive_time = now
            if attachment is not None:
                self._last_attachment = attachment
                count_source(self.sources, attachment.to_bytes(), now, sn)
            if self._waiting:
                self._cv.notify_all()
        if self._worker is not None:
            self._kick.put(None)
        elif self._inline:
            self._call(msg)

    @property
    def last_publisher(self) -> str:
        """Name of the node that sent the last valid message ("" if unknown)."""
        att = self._last_attachment
        return att.to_bytes().decode(errors="replace") if att is not None else ""

    def _deliver(self) -> None:
        # Woken through a SimpleQueue (a C lock, no Python-level Condition on either side): the hand-off
        # from Zenoh's thread is on every message's path. A token with nothing queued (the message was
        # overwritten in 'latest' mode) is skipped; close() sends one more token.
        while True:
            self._kick.get()
            with self._cv:
                if self._closed:
                    return
                if not self._queue:
                    continue
                msg = self._queue.popleft()
            self._call(msg)

    def _call(self, msg: Any) -> None:
        try:
            self._callback(msg)
        except Exception:
            self.errors += 1
            self._warn(log, f"[{self._node.name}] callback for '{self.topic}' raised:\n"
                            f"{traceback.format_exc()}")

    def stats(self) -> tuple[tuple[str, str, int, int, int, int, int], ...]:
        """(topic, type, received, malformed, invalid, dropped, callback errors) for the node's stats."""
        kind = getattr(self.msg_type, "_msg_name", "*")
        return ((self.topic, kind, self.received, self.malformed, self.invalid, self.dropped, self.errors),)

    def latest(self) -> Any:
        """The newest message received, or None."""
        return self._latest

    def age(self) -> float:
        """Wall seconds since the last valid message (inf if none)."""
        return time.monotonic() - self.last_receive_time if self.received else float("inf")

    def _wait_for(self, pred: Callable[[], bool], timeout: float | None) -> bool:
        """Condition.wait_for, counted in ``_waiting`` (call with ``_cv`` held)."""
        self._waiting += 1
        try:
            return self._cv.wait_for(pred, timeout)
        finally:
            self._waiting -= 1

    def wait(self, timeout: float = 5.0) -> Any:
        """Wait for the next message received after this call. Raises TimeoutError."""
        with self._cv:
            n = self.received
            if not self._wait_for(lambda: self.received > n or self._closed, timeout):
                raise TimeoutError(f"no message on '{self.topic}' within {timeout:.1f} s")
            return self._latest

    def wait_first(self, timeout: float = 5.0) -> Any:
        """The latest message, waiting for one if none arrived yet. Raises TimeoutError."""
        with self._cv:
            if not self._wait_for(lambda: self.received > 0, timeout):
                raise TimeoutError(f"no message on '{self.topic}' within {timeout:.1f} s")
            return self._latest

    def get(self, timeout: float | None = 5.0) -> Any:
        """Pop the oldest queued message (queue mode, no callback). Raises TimeoutError."""
        with self._cv:
            if not self._wait_for(lambda: bool(self._queue), timeout):
                raise TimeoutError(f"no message on '{self.topic}' within {timeout} s")
            return self._queue.popleft()

    def threads(self) -> list[threading.Thread]:
        """Its callback thread (which may be inside Zenoh: a callback that publishes or calls a service),
        for the node to join on close."""
        return [self._worker] if self._worker is not None else []

    def close(self) -> None:
        with self._cv:
            self._closed = True
            self._cv.notify_all()
        self._kick.put(None)
        for ent in (self._sub, self._pub_watch):
            with contextlib.suppress(zenoh.ZError):
                ent.undeclare()
