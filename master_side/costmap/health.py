"""Is each costmap's sensor data arriving? Both ends of ``<costmap>/sensors`` (``CostmapSensors``), pure.

The costmap node keeps a ``SensorWatch``: per observation source, what arrived on its topic and whether
it reached the costmap, turned into a ``CostmapSensors`` message with one state per source:

- ``late``: ROS ``expected_update_rate`` — the last reading is older than that many seconds (0: unchecked);
- ``silent``: zenav's addition — nothing delivered since the costmap started, whatever the rate, once a
  short grace (default ``GRACE_S``) has passed: a topic name nothing publishes leaves the robot blind;
- ``ok`` otherwise.

Other nodes read the messages with ``SensorHealth``::

    health = SensorHealth(required=("local_costmap",))
    on_report = lambda m: health.update(m, time.monotonic())
    node.subscribe("local_costmap/sensors", CostmapSensors, callback=on_report, mode="queue")
    node.subscribe("global_costmap/sensors", CostmapSensors, callback=on_report, mode="queue")
    why = health.problem(time.monotonic(), max_age=3.0)   # "" when every source is fine

The reports go out at 1 Hz of wall time whatever the clock does, so their age is measured in wall time
from their arrival: at 2x simulated time a report's stamp ages 2 s between two reports.
"""

from __future__ import annotations

import threading
from collections.abc import Iterable
from dataclasses import dataclass

from common.messages import CostmapSensors, Header, ObservationSourceStatus
from master_side.costmap.observation import ObservationBuffer

__all__ = ["GRACE_S", "OK", "LATE", "SILENT", "SensorWatch", "SensorHealth", "summary", "publisher_hint"]

GRACE_S = 1.0
OK, LATE, SILENT = ObservationSourceStatus.OK, ObservationSourceStatus.LATE, ObservationSourceStatus.SILENT


def publisher_hint(topic: str) -> str:
    return (f"nothing publishes '{topic}' — check the sensor node / topic name; "
            "`zenav topic list` shows what is published")


# -- the costmap node's side ---------------------------------------------------------------------------
@dataclass
class _Source:
    layer: str
    buffer: ObservationBuffer
    kind: str  # the bus message type subscribed to
    messages: int = 0  # received on the topic
    dropped: int = 0  # received but not usable since the last reading that was
    malformed: int = 0  # payloads on the topic that are not ``kind``
    why: str = ""  # why the last dropped message was not usable
    state: str = OK

    @property
    def topic(self) -> str:
        return (self.buffer.params.topic or self.buffer.name).strip("/")

    def head(self) -> str:
        return f"source '{self.buffer.name}' on topic '{self.topic}' ({self.buffer.params.data_type})"


class SensorWatch:
    """Per observation source: messages received / dropped (the node tells it) and readings buffered
    (``ObservationBuffer.last_updated``). Not thread-safe: the node calls it under its lock.

    Times: ``now`` is the costmap's clock (sim or wall, as ``last_updated``); ``mono`` a monotonic wall
    clock for the time since start (a simulated clock may not run yet).
    """

    def __init__(self, costmap: str, started: float, grace: float = GRACE_S) -> None:
        self.costmap, self.started, self.grace = costmap, started, grace
        self.sources: dict[tuple[str, str], _Source] = {}

    def add(self, layer: str, buffer: ObservationBuffer, kind: str | None = None) -> None:
        self.sources[(layer, buffer.name)] = _Source(layer, buffer, kind or buffer.params.data_type)

    # Sources of a disabled layer are not watched, and a reading can arrive before ``add``: ignore those.
    def received(self, layer: str, source: str) -> None:
        if (s := self.sources.get((layer, source))) is not None:
            s.messages += 1

    def dropped(self, layer: str, source: str, why: str) -> None:
        if (s := self.sources.get((layer, source))) is not None:
            s.dropped, s.why = s.dropped + 1, why

    def used(self, layer: str, source: str) -> None:
        if (s := self.sources.get((layer, source))) is not None:
            s.dropped, s.why = 0, ""

    def malformed(self, layer: str, source: str, count: int) -> None:
        if (s := self.sources.get((layer, source))) is not None:
            s.malformed = count

    def _status(self, s: _Source, now: float, elapsed: float) -> ObservationSourceStatus:
        buf, p = s.buffer, s.buffer.params
        rate = p.expected_update_rate
        delivered = buf.last_updated is not None
        if delivered:
            age = max(0.0, now - buf.last_updated)
            state = OK if buf.is_current(now) else LATE
        else:
            age = elapsed
            state = SILENT if elapsed >= self.grace or (rate > 0 and elapsed > rate) else OK
        if state == SILENT:
            detail = f"{s.head()} has delivered nothing since start {elapsed:.1f} s ago"
            if s.why:
                detail += f": {s.messages} message(s) arrived, none usable (last: {s.why})"
            elif s.messages:  # received, neither buffered nor dropped yet: still being processed
                detail += f": {s.messages} message(s) arrived, none processed yet"
            elif s.malformed:
                detail += f": {s.malformed} payload(s) on the topic are not {s.kind} (data_type)"
        elif state == LATE:
            detail = f"{s.head()} is late: last reading {age:.1f} s ago, expected_update_rate {rate:g} s"
            if s.dropped:
                detail += f"; {s.dropped} message(s) since, not usable (last: {s.why})"
        elif delivered:
            detail = f"{s.head()}: last reading {age:.2f} s ago"
        else:
            detail = f"{s.head()}: waiting for the first reading ({elapsed:.1f} s)"
        return ObservationSourceStatus(buf.name, s.layer, s.topic, p.data_type, delivered, s.messages,
                                       float(age), float(rate), state, detail)

    def report(self, header: Header, now: float, mono: float) -> tuple[CostmapSensors, list[tuple[str, str]]]:
        """The status message and the log lines for sources whose state changed: (level, text) with
        level WARNING (now late / silent) or INFO (recovered)."""
        elapsed = max(0.0, mono - self.started)
        out, events = [], []
        for s in self.sources.values():
            st = self._status(s, now, elapsed)
            out.append(st)
            if st.state != s.state:
                if st.state == OK:
                    events.append(("INFO", f"{self.costmap}: recovered ({s.state} before): {st.detail}"))
                else:
                    hint = f"; {publisher_hint(s.topic)}" if st.state == SILENT and not s.messages else ""
                    events.append(("WARNING", f"{self.costmap}: {st.detail}{hint}"))
                s.state = st.state
        return CostmapSensors(header, self.costmap, tuple(out)), events


# -- the readers' side ---------------------------------------------------------------------------------
def summary(msg: CostmapSensors) -> str:
    """One line for a costmap's sensors: its problems, or how many sources are fine."""
    bad = msg.problems()
    if bad:
        return f"{msg.costmap}: " + "; ".join(s.detail for s in bad)
    if not msg.sources:
        return f"{msg.costmap}: no observation sources"
    names = ", ".join(f"'{s.source}' on '{s.topic}'" for s in msg.sources)
    return f"{msg.costmap}: {len(msg.sources)} source(s) ok ({names})"


class SensorHealth:
    """The latest ``CostmapSensors`` of each costmap, as one line and a boolean. Thread-safe: ``update``
    may run on a bus thread while ``problem`` runs in a control loop.

    ``required``: costmap names that must report; one that never did is a problem too (without it a
    costmap that was never heard of is ignored).
    """

    def __init__(self, required: Iterable[str] = ()) -> None:
        self.required = tuple(required)
        self._latest: dict[str, tuple[float, CostmapSensors]] = {}
        self._lock = threading.Lock()

    def update(self, msg: CostmapSensors, received: float | None = None) -> None:
        """Keep ``msg``; its age is counted from ``received`` (default: its header stamp)."""
        t = msg.header.stamp if received is None else received
        with self._lock:
            self._latest[msg.costmap] = (t, msg)

    def latest(self, costmap: str) -> CostmapSensors | None:
        with self._lock:
            got = self._latest.get(costmap)
        return None if got is None else got[1]

    def problem(self, now: float, max_age: float = 3.0) -> str:
        """Empty when every source of every costmap is ok, else one line naming each problem (a costmap
        whose last message is older than ``max_age`` s, or required and never heard, is "not reporting")."""
        with self._lock:
            latest = dict(self._latest)
        parts = []
        for name in sorted(set(self.required) | set(latest)):
            got = latest.get(name)
            if got is None:
                parts.append(f"costmap {name} not reporting (nothing on {name}/sensors yet)")
            elif now - got[0] > max_age:
                parts.append(f"costmap {name} not reporting (last {name}/sensors {now - got[0]:.1f} s ago)")
            else:
                parts += [f"{name}: {s.detail}" for s in got[1].problems()]
        return "; ".join(parts)

    def ok(self, now: float, max_age: float = 3.0) -> bool:
        return not self.problem(now, max_age)
