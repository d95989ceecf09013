"""The simulator's ``clock`` topic, taken when a node looks at its time rather than pushed per message.

The simulator publishes ``clock`` every physics step (100 Hz). Delivered as ordinary messages, each one
woke every sim-time node: Zenoh's thread, the GIL, a decode, the subscription's bookkeeping, the clock's
condition — measured 0.30 s of CPU per 10 s per node (0.16 s of it in Zenoh's callback alone), about
3 % of a core for each of the ten nodes of a stack, spent on ticks nobody was waiting for.

Here Zenoh keeps only the newest sample, in its own memory (a ring of one), and no Python code runs when
it arrives. The ``SimClock`` takes it when a thread reads the time or a sleeper looks (``SimClock(pull=…)``
sleeps in steps sized by the time still to wait), and the node's route watch takes it every 0.5 s, so a
clock whose route went silent is still noticed and declared again (common.route_watch). ``received``
counts the samples taken, not the samples published.
"""

from __future__ import annotations

import contextlib
import threading
import time

import zenoh

from common.bus_topics import topic_key
from common.codec import DecodeError, decode
from common.messages import Clock
from common.route_watch import count_source


class ClockTopic:
    """Feeds ``clock`` (a ``SimClock``) from the ``clock`` topic on ``pull()``; watched like a subscription."""

    topic = "clock"
    msg_type = Clock

    def __init__(self, session: zenoh.Session, robot: str, clock) -> None:
        self.key = topic_key(robot, self.topic)
        self._session, self._clock = session, clock
        self._lock = threading.Lock()  # the counters (pulls come from any thread)
        self.received = self.malformed = self.invalid = 0
        self.sources: dict[bytes, list] = {}  # (common.route_watch)
        self._closed = False
        self._sub = session.declare_subscriber(self.key, zenoh.handlers.RingChannel(1))

    @property
    def closed(self) -> bool:
        return self._closed

    def pull(self) -> None:
        """Give the clock the newest value that came since the last pull (if any)."""
        try:
            sample = self._sub.try_recv()
        except zenoh.ZError:  # undeclared (closing, or being declared again)
            return
        if sample is None:
            return
        try:
            msg = decode(sample.payload.to_bytes(), Clock)
        except DecodeError:
            with self._lock:
                self.malformed += 1
            return
        if not msg.clock >= 0.0:  # NaN or negative: not a time
            with self._lock:
                self.invalid += 1
            return
        who = sample.attachment.to_bytes() if sample.attachment is not None else b""
        with self._lock:
            self.received += 1
            count_source(self.sources, who, time.monotonic())
        self._clock.update(msg.clock)

    def redeclare(self) -> None:
        """Declare the Zenoh subscriber again (common.route_watch)."""
        with self._lock:  # the old one first, as Subscription.redeclare (a pull meanwhile takes nothing)
            if self._closed:
                return
            with contextlib.suppress(zenoh.ZError):
                self._sub.undeclare()
            self._sub = self._session.declare_subscriber(self.key, zenoh.handlers.RingChannel(1))

    def stats(self) -> tuple[tuple[str, str, int, int, int, int, int], ...]:
        """As ``Subscription.stats``: (topic, type, received, malformed, invalid, dropped, callback errors)."""
        return ((self.topic, "Clock", self.received, self.malformed, self.invalid, 0, 0),)

    def close(self) -> None:
        with self._lock:
            self._closed = True
        with contextlib.suppress(zenoh.ZError):
            self._sub.undeclare()
