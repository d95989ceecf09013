"""`bench/bus.py --stages`: where a LaserScan's one-way latency goes, stage by stage.

Both processes are on one host, so time.time() stamps taken in each compare directly:

    stamp ─ message + encode ─ put() called ─ Zenoh ─ receive entered ─ decode + checks ─ hop ─ callback

(the four stages add up to the one-way latency; "put call" is the part of Zenoh's stage that the
publishing thread spends inside put()).

The publisher's put and the subscription's receive function are wrapped (a few time.time() calls per
message, off by default: the headline figure is measured without them)."""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from common import bus_topics

STAGES = ("message+encode", "zenoh", "decode+checks", "hop", "put call")


class TimedPut:
    """Stands in for a Zenoh publisher: times each put (before, after)."""

    def __init__(self, pub: Any) -> None:
        self._pub, self.last = pub, (0.0, 0.0)
        self.matching_status = pub.matching_status

    def put(self, data: Any, **kw: Any) -> None:
        t = time.time()
        self._pub.put(data, **kw)
        self.last = (t, time.time())


def time_receive(topic: str, out: dict[str, tuple[float, float]]) -> None:
    """Record (entered, decoded and checked) per frame_id of ``topic``'s messages in ``out``; call before
    subscribing (Zenoh keeps the bound method it was given)."""
    receive = bus_topics.Subscription._on_sample

    def timed(self: bus_topics.Subscription, sample: Any) -> None:
        if self.topic != topic:
            return receive(self, sample)
        t = time.time()
        n = self.received
        receive(self, sample)
        if self.received > n:
            out[self._latest.header.frame_id] = (t, time.time())
        return None

    bus_topics.Subscription._on_sample = timed


def stage_p50_ms(pub: dict[str, tuple[float, float, float]], sub: dict[str, list[float]],
                 delivered: dict[str, float]) -> dict[str, float]:
    """p50 of each stage over the messages seen at every point; ``pub``: frame_id -> (stamp, put start,
    put end); ``sub``: frame_id -> (entered, checked); ``delivered``: frame_id -> callback time."""
    rows = [(p[0], p[1], p[2], sub[k][0], sub[k][1], delivered[k])
            for k, p in pub.items() if k in sub and k in delivered]
    if not rows:
        return {s: float("nan") for s in STAGES}
    a = np.asarray(rows) * 1e3
    cols = (a[:, 1] - a[:, 0], a[:, 3] - a[:, 1], a[:, 4] - a[:, 3], a[:, 5] - a[:, 4], a[:, 2] - a[:, 1])
    return {s: float(np.median(c)) for s, c in zip(STAGES, cols)}
