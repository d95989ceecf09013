"""common.clock.Timer's event-driven mode (costmap ``update_on_observation``, move_base
``control_on_costmap``): a kick runs at once when a period has passed since the last run, else one period
after it; without kicks every IDLE_PERIODS periods (at least IDLE_MIN_S). A step clock shows when the
timer plans to wake, so the schedule is checked exactly, without racing the timer's thread."""

from __future__ import annotations

import threading

from common.clock import Timer


class StepClock:
    """Time moves only when the test says so; records every wake-up time the timer asks for."""

    def __init__(self) -> None:
        self.t = 0.0
        self.cv = threading.Condition()
        self.targets: list[float] = []

    def now(self) -> float:
        return self.t

    def wake(self) -> None:
        with self.cv:
            self.cv.notify_all()

    def sleep_until(self, t: float, cancel: threading.Event | None = None) -> bool:
        with self.cv:
            self.targets.append(t)
            self.cv.notify_all()
            while self.t < t and not cancel.is_set():
                self.cv.wait(0.5)
            return not cancel.is_set()

    def advance(self, t: float) -> None:
        with self.cv:
            self.t = t
            self.cv.notify_all()

    def next_target(self, n: int) -> float:
        """The timer's wake-up time once it has asked for more than ``n`` of them."""
        with self.cv:
            assert self.cv.wait_for(lambda: len(self.targets) > n, 10.0), "the timer never slept again"
            return self.targets[-1]


def _timer(on_data: bool):
    clock, runs = StepClock(), []
    timer = Timer(clock, 1.0, lambda: runs.append(clock.now()), on_data=on_data)
    return clock, runs, timer


def test_kicks_align_runs_with_data_but_never_faster_than_the_period():
    clock, runs, timer = _timer(on_data=True)
    try:
        assert clock.next_target(0) == 2.0  # no data yet: an idle run after IDLE_PERIODS periods
        clock.advance(0.5)
        n = len(clock.targets)
        timer.kick()  # the first data: run now
        assert clock.next_target(n) == 2.5 and runs == [0.5]
        clock.advance(0.8)
        n = len(clock.targets)
        timer.kick()  # 0.3 s after a run: wait for the period
        assert clock.next_target(n) == 1.5 and runs == [0.5]
        n = len(clock.targets)
        clock.advance(1.5)
        assert clock.next_target(n) == 3.5 and runs == [0.5, 1.5]
        clock.advance(2.9)
        n = len(clock.targets)
        timer.kick()  # 1.4 s after the last run: at once
        assert clock.next_target(n) == 4.9 and runs == [0.5, 1.5, 2.9]
        n = len(clock.targets)
        clock.advance(4.9)  # no data: idle run
        assert clock.next_target(n) == 6.9 and runs == [0.5, 1.5, 2.9, 4.9]
        assert timer.kicks == 3
    finally:
        timer.cancel()
        timer.join()
    assert not timer.thread.is_alive()


def test_a_fixed_rate_timer_ignores_kicks():
    clock, runs, timer = _timer(on_data=False)
    try:
        assert clock.next_target(0) == 1.0
        clock.advance(0.5)
        timer.kick()
        n = len(clock.targets)
        clock.advance(1.0)
        assert clock.next_target(n) == 2.0 and runs == [1.0] and timer.kicks == 0
    finally:
        timer.cancel()
        timer.join()
    assert not timer.thread.is_alive()
