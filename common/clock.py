"""Time for nodes: wall time, or simulated time driven by the simulator's ``clock`` topic.

Rates and timeouts of a node follow its clock, so a simulation can run faster (or slower) than
real time. ``ZENAV_USE_SIM_TIME=1`` makes ``Node`` use a ``SimClock`` fed from ``clock``.
"""

from __future__ import annotations

import heapq
import itertools
import threading
import time


class WallClock:
    simulated = False

    def now(self) -> float:
        return time.time()

    def sleep(self, seconds: float) -> None:
        if seconds > 0:
            time.sleep(seconds)

    def sleep_until(self, t: float, cancel: threading.Event | None = None) -> bool:
        """Sleep until clock time ``t``; returns False if ``cancel`` was set first."""
        delay = t - self.now()
        if cancel is not None:
            return not cancel.wait(max(0.0, delay))
        self.sleep(delay)
        return True

    def wake(self) -> None:
        """Nothing to do: a wall-clock sleeper waits on its cancel event itself (``SimClock.wake``)."""


class SimClock:
    """Simulated time: advances only when ``update`` is called (from the ``clock`` topic).

    ``now()`` is 0.0 until the first clock message, as in ROS. A sleeper is woken when its own deadline
    is reached (or by ``wake`` / ``close``), not on every clock message: at 100 Hz, waking each timer
    thread of each node per message cost more CPU than the timers' work.
    """

    simulated = True
    POLL_S = 0.25  # a sleeper also looks at its cancel event this often (wake() makes it look at once)

    def __init__(self) -> None:
        self._t = 0.0
        self._lock = threading.Lock()
        self._sleepers: list[tuple[float, int, threading.Event]] = []  # heap by deadline
        self._seq = itertools.count()
        self._closed = False

    def update(self, t: float) -> None:
        with self._lock:
            if t <= self._t:
                return
            self._t = t
            due = []
            while self._sleepers and self._sleepers[0][0] <= t:
                due.append(heapq.heappop(self._sleepers)[2])
        for ev in due:
            ev.set()

    def close(self) -> None:
        with self._lock:
            self._closed = True
        self.wake()

    def now(self) -> float:
        return self._t

    def wake(self) -> None:
        """Let sleepers check their cancel event now (a kicked timer) instead of at their deadline."""
        with self._lock:
            sleepers, self._sleepers = self._sleepers, []
        for _, _, ev in sleepers:
            ev.set()

    def sleep(self, seconds: float) -> None:
        self.sleep_until(self._t + seconds)

    def sleep_until(self, t: float, cancel: threading.Event | None = None) -> bool:
        ev, queued = threading.Event(), False
        while not (cancel is not None and cancel.is_set()):
            with self._lock:
                if self._closed or self._t >= t:
                    break
                if not queued:  # once per sleep; again only after update / wake took the entry out
                    ev.clear()
                    heapq.heappush(self._sleepers, (t, next(self._seq), ev))
                    queued = True
            if ev.wait(self.POLL_S):
                queued = False
        return not (cancel is not None and cancel.is_set()) and not self._closed


class Timer:
    """Calls ``fn()`` every ``period`` seconds of ``clock`` on its own thread until cancelled.

    ``on_data=True`` (zenav's event-driven mode): ``kick()`` asks for a run as soon as new data is there.
    It runs at once if ``period`` has passed since the last run, else when it has (so never more often
    than 1/period); without kicks it still runs every ``IDLE_PERIODS`` periods or ``IDLE_MIN_S``, whichever
    is longer (so a sensor slower than the timer's rate never meets an idle run just before its data).
    The run is then aligned with the data instead of a free-running phase."""

    IDLE_PERIODS, IDLE_MIN_S = 2.0, 0.5

    def __init__(self, clock, period: float, fn, name: str = "timer", on_error=None, on_data: bool = False) -> None:
        if period <= 0:
            raise ValueError("timer period must be > 0")
        self._clock, self._period, self._fn, self._on_error = clock, period, fn, on_error
        self._cancel = threading.Event()
        self._wake = threading.Event()  # set by kick() and cancel(): ends the current sleep
        self._on_data = on_data
        self.overruns = 0
        self.last_duration = 0.0
        self.kicks = 0
        self.thread = threading.Thread(target=self._run if not on_data else self._run_on_data, name=name,
                                        daemon=True)
        self.thread.start()

    def _call(self) -> None:
        t0 = time.perf_counter()
        try:
            self._fn()
        except Exception as e:  # a failing callback must not kill the node
            if self._on_error is not None:
                self._on_error(e)
        self.last_duration = time.perf_counter() - t0

    def _run(self) -> None:
        next_t = self._clock.now() + self._period
        while self._clock.sleep_until(next_t, self._cancel):
            self._call()
            next_t += self._period
            now = self._clock.now()
            if next_t < now:  # fell behind: skip missed ticks rather than bursting
                self.overruns += 1
                next_t = now + self._period

    def _run_on_data(self) -> None:
        last, idle = float("-inf"), max(self._period * self.IDLE_PERIODS, self.IDLE_MIN_S)
        next_t = self._clock.now() + idle
        while True:
            slept = self._clock.sleep_until(next_t, self._wake)
            if self._cancel.is_set() or not (slept or self._wake.is_set()):  # cancelled, or the clock closed
                return
            if not slept:  # kicked: run now if a period has passed, else when it has
                self._wake.clear()
                self.kicks += 1
                due = last + self._period
                if self._clock.now() < due:
                    next_t = min(next_t, due)
                    continue
            last = self._clock.now()
            self._call()
            next_t = last + idle

    def kick(self) -> None:
        """New data: run soon (``on_data`` timers; a no-op for fixed-rate ones)."""
        if self._on_data:
            self._wake.set()
            self._clock.wake()

    def cancel(self) -> None:
        self._cancel.set()
        self._wake.set()
        self._clock.wake()

    def join(self, timeout: float = 2.0) -> None:
        if threading.current_thread() is not self.thread:
            self.thread.join(timeout)
