"""When to log: per-entity rate limits (latest wins) and the ``stamp`` timeline (wall or sim time).

Pure helpers (no rerun / zenoh) so they are unit-testable.
"""

from __future__ import annotations

import time
from typing import Any, Callable

from common.messages import REGISTRY

# Default max logging rate per message type (Hz); 0 or absent = every message.
DEFAULT_RATES: dict[str, float] = {
    "OccupancyGrid": 0.5, "Costmap": 2.0, "PointCloud": 2.0, "DepthImage": 2.0, "LaserScan": 10.0,
    "Odometry": 10.0, "Twist": 20.0, "Path": 5.0, "PolygonStamped": 5.0, "TFMessage": 20.0,
    "Scalar": 10.0, "MoveBaseStatus": 5.0, "PoseStamped": 5.0, "BatteryState": 1.0,
    "ParticleCloud": 2.0,  # AMCL's particlecloud (a Path of poses): the heaviest per-update stream
}

# With --serve-web, the rates above are lowered to these unless --rate says otherwise: a browser's viewer
# on a machine without a GPU (headless Chromium's software rasterizer here) takes in less than the 0.76 MB/s
# the monitor sends at the rates above. It takes data in only while it draws a frame, so what counts is the
# number of chunks: plots and TF, 75 % of them at 2 and 5 Hz, are at 1 and 2 Hz here. At these rates it sends
# 0.12 MB/s and a page caught up with its history stays live (bench/monitor_live.py, README "Watching it").
WEB_RATES: dict[str, float] = {
    "OccupancyGrid": 0.2, "Costmap": 0.25, "PointCloud": 0.5, "DepthImage": 0.2, "LaserScan": 2.0,
    "Odometry": 2.0, "Twist": 1.0, "Path": 1.0, "PolygonStamped": 2.0, "TFMessage": 2.0, "Scalar": 1.0,
    "MoveBaseStatus": 1.0, "PoseStamped": 1.0, "BatteryState": 0.5, "ParticleCloud": 0.5,
}

# Stamps below this are simulated seconds since start (a wall stamp is > 1.6e9).
SIM_STAMP_MAX = 1e8


def parse_rates(items: list[str]) -> dict[str, float]:
    """``["Costmap=1", "scan=5"]`` -> {name: hz}. A name is a message type or a topic."""
    rates: dict[str, float] = {}
    for item in items:
        for part in item.split(","):
            name, sep, hz = part.partition("=")
            name = name.strip().strip("/")
            try:
                value = float(hz)
            except ValueError:
                value = -1.0
            if not sep or not name or value < 0:
                raise ValueError(f"--rate expects TYPE=HZ or TOPIC=HZ with HZ >= 0, got {part!r}")
            if name[0].isupper() and name not in REGISTRY and name not in DEFAULT_RATES:
                known = ", ".join(sorted(REGISTRY))
                raise ValueError(f"--rate: unknown message type {name!r} (known: {known})")
            rates[name] = value
    return rates


class Throttle:
    """Per-entity rate limiter that never loses the newest state.

    A message arriving too soon after the previous one logged at the same entity is kept as *pending*
    (replacing an older pending one, which is counted as dropped); ``due()`` hands pending messages
    over once their entity's period has passed, so the last costmap before a pause is still shown.
    Rates come from the topic name first, then the message type.
    """

    def __init__(self, rates: dict[str, float] | None = None, clock: Callable[[], float] = time.monotonic):
        self.rates = dict(DEFAULT_RATES, **(rates or {}))
        self.clock = clock
        self._last: dict[str, float] = {}
        self._pending: dict[str, tuple[float, Any]] = {}  # entity -> (period, item)
        self.dropped = 0

    def period(self, topic: str, kind: str) -> float:
        hz = self.rates.get(topic, self.rates.get(kind, 0.0))
        return 1.0 / hz if hz > 0 else 0.0

    def offer(self, entity: str, period: float, item: Any) -> bool:
        """True: log ``item`` now (and it is marked logged). False: kept pending."""
        now = self.clock()
        last = self._last.get(entity)
        if period > 0 and last is not None and now - last < period:
            if entity in self._pending:
                self.dropped += 1
            self._pending[entity] = (period, item)
            return False
        self._last[entity] = now
        if self._pending.pop(entity, None) is not None:
            self.dropped += 1
        return True

    def due(self, flush_all: bool = False) -> list[tuple[str, Any]]:
        """Pending items whose period has passed (all of them with ``flush_all``); marks them logged."""
        now = self.clock()
        out = []
        for entity, (period, item) in list(self._pending.items()):
            if flush_all or now - self._last.get(entity, -1e18) >= period:
                del self._pending[entity]
                self._last[entity] = now
                out.append((entity, item))
        return out


class StampTimeline:
    """Maps message stamps to the ``stamp`` timeline.

    The first non-zero stamp decides the kind for the whole recording: simulated time (small stamps)
    becomes a *duration*, wall time a *timestamp* — a timeline cannot mix both. A stamp of 0 ("no
    time") or of the other kind (e.g. an agent stamping wall time during a simulated run) is placed at
    the newest stamp seen so far. Returns None before any stamp is known.
    """

    def __init__(self) -> None:
        self.kind: str | None = None  # "duration" | "timestamp"
        self.latest: float | None = None
        self.mismatched = 0

    def resolve(self, stamp: float | None) -> tuple[str, float] | None:
        if stamp is not None and stamp > 0 and stamp == stamp:
            kind = "duration" if stamp < SIM_STAMP_MAX else "timestamp"
            if self.kind is None:
                self.kind = kind
            if kind == self.kind:
                if self.latest is None or stamp > self.latest:
                    self.latest = stamp
                return self.kind, stamp
            self.mismatched += 1
        if self.kind is None or self.latest is None:
            return None
        return self.kind, self.latest
