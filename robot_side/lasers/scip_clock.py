"""Hokuyo sensor clock -> host clock: the 24-bit millisecond counter of SCIP 2.0 replies, unwrapped,
offset from TM1 round trips and kept honest against drift (sources: docs/hokuyo-scip.md)."""

from __future__ import annotations

import numpy as np

WRAP_MS = 1 << 24  # the timestamp counter is 24 bits of milliseconds (~4.66 h)


class ClockSync:
    """Sensor 24-bit millisecond counter -> host seconds.

    ``calibrate`` takes TM1 round trips (host send time, counter, host receive time) and sets
    offset = host - sensor from the fastest half of them (their mid-points). ``stamp`` unwraps the
    counter and keeps the offset honest against clock drift: the smallest (receipt - stamp) of each
    ``window`` scans is held at the value seen in the first window, and a stamp is never later than
    the host time the scan was received."""

    def __init__(self, window: int = 50) -> None:
        self.offset: float | None = None
        self.window = window
        self._last_raw: int | None = None
        self._wraps = 0
        self._base_lag: float | None = None
        self._lags: list[float] = []

    def unwrap(self, raw_ms: int) -> int:
        raw_ms &= WRAP_MS - 1
        if self._last_raw is not None and raw_ms < self._last_raw - WRAP_MS // 2:
            self._wraps += 1
        self._last_raw = raw_ms
        return raw_ms + self._wraps * WRAP_MS

    def calibrate(self, samples: list[tuple[float, int, float]]) -> float:
        if not samples:
            raise ValueError("no TM1 samples")
        rows = sorted(((t1 - t0), (t0 + t1) / 2.0 - self.unwrap(ms) * 1e-3) for t0, ms, t1 in samples)
        best = [off for _, off in rows[:max(1, len(rows) // 2)]]
        self.offset = float(np.median(best))
        return self.offset

    def stamp(self, raw_ms: int, received: float) -> float:
        t = self.unwrap(raw_ms) * 1e-3
        if self.offset is None:
            self.offset = received - t
        lag = received - (t + self.offset)
        if lag < 0.0:
            self.offset += lag
            lag = 0.0
        self._lags.append(lag)
        if len(self._lags) >= self.window:
            low = min(self._lags)
            self._lags.clear()
            if self._base_lag is None:
                self._base_lag = low
            else:
                self.offset += low - self._base_lag
        return t + self.offset
