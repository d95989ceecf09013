"""The `zenav play` engine: LogRecords onto the bus at the log's pace, with a ``clock`` topic.

``Player(node, records, info, PlayOptions(...)).run(stop)`` publishes every record on its topic
(renamed by ``remap``; ``tf_static`` and ``map`` latched, ``tf_static`` accumulated so a late listener
gets every static transform), paced by wall time at ``rate`` log seconds per wall second. The
``clock`` topic (common.messages.Clock, what nodes with ZENAV_USE_SIM_TIME=1 follow) ticks at least
every ``clock_step`` of log time and once before each message, so every node runs on the log's time;
after the last message it ticks ``end_tick`` further (a node waiting for a transform past the end of
the log times out instead of waiting forever). ``loop`` replays with every stamp shifted by the
played span, so the clock never goes backwards. Usable in-process (tests) and by deploy.cli.play.
"""

from __future__ import annotations

import collections
import dataclasses
import math
import threading
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from typing import Any, TextIO

from common.messages import Clock, Header, TFMessage
from deploy.logs import LogRecord

LATCHED = ("tf_static", "map")


@dataclass(frozen=True)
class PlayOptions:
    rate: float = 1.0  # log seconds per wall second
    start: float = 0.0  # skip the first ``start`` log seconds (static transforms are still sent)
    duration: float | None = None  # play this many log seconds (None: to the end)
    loop: bool = False
    remap: dict[str, str] = field(default_factory=dict)  # log topic -> bus topic
    topics: frozenset[str] | None = None  # log topics to play (None: all)
    clock: bool = True
    clock_step: float = 0.01  # s of log time between clock ticks at most
    end_tick: float = 1.0  # s of log time the clock runs on after the last message
    wait_for: tuple[str, ...] = ()  # bus topics that must have a subscriber before playing
    wait_timeout: float = 30.0  # wall s
    delay: float = 0.0  # wall s between the publishers' creation and the first message


@dataclass
class PlayStats:
    sent: collections.Counter = field(default_factory=collections.Counter)  # bus topic -> messages
    clock_ticks: int = 0
    first: float | None = None  # log stamps of the played span (absolute, before loop shifts)
    log_t: float = 0.0  # clock now (absolute, loop shifts included)
    played_s: float = 0.0  # log seconds played
    wall_s: float = 0.0
    loops: int = 0  # completed passes
    lag_max_s: float = 0.0  # largest wall delay behind the schedule

    @property
    def messages(self) -> int:
        return sum(self.sent.values())

    @property
    def rate_achieved(self) -> float:
        return self.played_s / self.wall_s if self.wall_s > 0 else 0.0


def shift_stamps(msg: Any, dt: float) -> Any:
    """The message with every Header stamp moved by ``dt`` (nested messages and tuples too)."""
    if isinstance(msg, Header):
        return Header(msg.stamp + dt, msg.frame_id)
    if not dataclasses.is_dataclass(msg) or isinstance(msg, type):
        return msg
    changes = {}
    for f in dataclasses.fields(msg):
        v = getattr(msg, f.name)
        if isinstance(v, Header) or (dataclasses.is_dataclass(v) and not isinstance(v, type)):
            changes[f.name] = shift_stamps(v, dt)
        elif isinstance(v, tuple) and v and dataclasses.is_dataclass(v[0]):
            changes[f.name] = tuple(shift_stamps(x, dt) for x in v)
    return dataclasses.replace(msg, **changes) if changes else msg


class Player:
    def __init__(self, node, records: Callable[[], Iterable[LogRecord]], info=None,
                 options: PlayOptions | None = None, progress: TextIO | None = None, every_s: float = 1.0):
        """``records()`` opens the log (called again for every loop pass); ``info`` (readers.LogInfo)
        gives the total for the progress line."""
        self.node, self.records, self.info = node, records, info
        self.o = options or PlayOptions()
        self.progress, self.every_s = progress, every_s
        self.stats = PlayStats()
        self._pubs: dict[str, Any] = {}
        self._static: dict[str, Any] = {}
        self._clock_pub = node.publisher("clock") if self.o.clock else None
        if self._clock_pub is not None:
            self._pubs["clock"] = self._clock_pub
        self._clock_t = -math.inf
        self._wall0: float | None = None
        self._play0: float | None = None
        self._last_progress = 0.0
        self._stop = threading.Event()

    def publisher(self, topic: str):
        """The bus publisher of a bus topic (created on first use)."""
        pub = self._pubs.get(topic)
        if pub is None:
            # reliable: the player waits rather than drop a message (as rosbag play's TCP links)
            pub = self._pubs[topic] = self.node.publisher(topic, latched=topic in LATCHED, reliable=True)
        return pub

    def bus_topic(self, topic: str) -> str:
        return self.o.remap.get(topic, topic)

    def wait_for_subscribers(self, topics: Iterable[str], timeout: float) -> list[str]:
        """Wait until each bus topic has a subscriber; returns those still without one."""
        missing = list(topics)
        deadline = time.monotonic() + timeout
        while missing and time.monotonic() < deadline and not self._stop.is_set():
            missing = [t for t in missing if not self.publisher(t)._pub.matching_status.matching]
            if missing:
                self._stop.wait(0.02)
        return missing

    def stop(self) -> None:
        self._stop.set()

    # -- playing ---------------------------------------------------------------------------------
    def run(self, stop: threading.Event | None = None) -> PlayStats:
        if stop is not None:
            def relay() -> None:
                stop.wait()
                self._stop.set()
            threading.Thread(target=relay, daemon=True).start()
        o = self.o
        for topic in (self.info.counts if self.info is not None else ()):
            if o.topics is None or topic in o.topics:
                self.publisher(self.bus_topic(topic))
        missing = self.wait_for_subscribers(o.wait_for, o.wait_timeout)
        if missing:
            raise TimeoutError(f"no subscriber of {', '.join(missing)} within {o.wait_timeout:g} s")
        if o.delay > 0:
            self._stop.wait(o.delay)
        t_wall = time.monotonic()
        offset, last = 0.0, None
        while not self._stop.is_set():
            last_pass = self._pass(self.records(), offset)
            if last_pass is None:  # nothing in the window
                break
            last = last_pass
            self.stats.loops += 1
            if not o.loop:
                break
            offset = last + o.clock_step - self.stats.first + offset
        if last is not None and not self._stop.is_set():
            self._advance(self._clock_t + o.end_tick)
        self.stats.wall_s = time.monotonic() - (self._wall0 if self._wall0 is not None else t_wall)
        self._report(final=True)
        return self.stats

    def _pass(self, records: Iterable[LogRecord], offset: float) -> float | None:
        """One pass over the log; returns the (unshifted) stamp of the last played record."""
        o, st = self.o, self.stats
        log0, last = None, None
        it: Iterator[LogRecord] = iter(records)
        try:
            for rec in it:
                if self._stop.is_set():
                    break
                if log0 is None:
                    log0 = rec.stamp
                if o.topics is not None and rec.topic not in o.topics:
                    continue
                begin = log0 + o.start
                if rec.stamp < begin:
                    if rec.topic == "tf_static":
                        self._publish(rec, offset)  # static state: sent whatever the window
                    continue
                if o.duration is not None and rec.stamp > begin + o.duration:
                    break
                if st.first is None:
                    st.first = begin
                t = rec.stamp + offset
                self._advance(t)
                self._publish(rec, offset)
                last = rec.stamp
                st.played_s = self._clock_t - (st.first if self._play0 is None else self._play0)
                self._report()
        finally:
            close = getattr(it, "close", None)
            if close is not None:
                close()
        return last

    def _advance(self, t: float) -> None:
        """Clock ticks every clock_step up to ``t``, then at ``t``, each at its wall time."""
        if self._wall0 is None:
            self._wall0, self._play0 = time.monotonic(), t
            self._clock_t = t - self.o.clock_step
        step = self.o.clock_step
        if self._clock_pub is not None:
            while self._clock_t + step < t and not self._stop.is_set():
                self._tick(self._clock_t + step)
        if t > self._clock_t:
            self._tick(t)

    def _tick(self, t: float) -> None:
        self._pace(t)
        self._clock_t = t
        self.stats.log_t = t
        if self._clock_pub is not None:
            self._clock_pub.publish(Clock(t))
            self.stats.clock_ticks += 1

    def _pace(self, t: float) -> None:
        delay = self._wall0 + (t - self._play0) / self.o.rate - time.monotonic()
        if delay > 0:
            self._stop.wait(delay)
        elif -delay > self.stats.lag_max_s:
            self.stats.lag_max_s = -delay

    def _publish(self, rec: LogRecord, offset: float) -> None:
        msg = shift_stamps(rec.msg, offset) if offset else rec.msg
        topic = self.bus_topic(rec.topic)
        if rec.topic == "tf_static" and isinstance(msg, TFMessage):  # one latched message holds them all
            for ts in msg.transforms:
                self._static[ts.child_frame_id] = ts
            msg = TFMessage(tuple(self._static.values()))
        self.publisher(topic).publish(msg)
        self.stats.sent[topic] += 1

    def _report(self, final: bool = False) -> None:
        if self.progress is None:
            return
        now = time.monotonic()
        if not final and now - self._last_progress < self.every_s:
            return
        self._last_progress = now
        st = self.stats
        wall = now - self._wall0 if self._wall0 is not None else 0.0
        rate = st.played_s / wall if wall > 0 else 0.0
        start = self.info.start if self.info is not None and self.info.start is not None else st.first
        pos = st.log_t - (start or 0.0)
        total = self.info.duration if self.info is not None else None
        of = f" / {total:.1f}" if total is not None else ""
        loop = f"  loop {st.loops + 1}" if self.o.loop else ""
        self.progress.write(f"\rlog {pos:8.1f}{of} s  wall {wall:7.1f} s  x{rate:5.2f} (target x{self.o.rate:g})"
                            f"  sent {st.messages} msgs{loop}   " + ("\n" if final else ""))
        self.progress.flush()
