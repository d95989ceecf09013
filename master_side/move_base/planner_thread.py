"""The global planner off the control path, as move_base's planThread.

``start(goal)`` makes the planner run: at once, then every 1 / planner_frequency s (0: once per
request; a failed attempt is retried at once), until ``stop()``. ``wake()`` (move_base calls it every
cycle while waiting for a plan) asks for an attempt now. ``poll()`` returns what finished since the
last poll: the newest plan, and how many attempts failed with the last error. Results for a goal
that has since been replaced are dropped.

Two implementations share the semantics: ``PlannerThread`` (a thread; the node) and
``ImmediatePlanner`` (plans inside ``poll``; tests and in-process benchmarks, where a deterministic
order matters more than latency).
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from common.geometry import Pose2D


@dataclass(frozen=True)
class PlanOutcome:
    path: np.ndarray | None = None  # newest plan since the last poll (N, 3), or None
    goal_used: Pose2D | None = None
    failures: int = 0  # failed attempts since the last poll
    error: str = ""  # the last failure's message
    seconds: float = 0.0  # duration of the newest attempt


NOTHING = PlanOutcome()


class _Schedule:
    """Shared bookkeeping: goal, generation, running flag, next due time, accumulated outcome."""

    def __init__(self, frequency: float):
        self.frequency = frequency
        self.goal: Pose2D | None = None
        self.generation = 0
        self.running = False
        self.wake_now = False
        self.next_due = -math.inf
        self._path = self._used = None
        self._failures, self._error, self._seconds = 0, "", 0.0

    def start(self, goal: Pose2D) -> None:
        self.goal, self.generation = goal, self.generation + 1
        self.running, self.wake_now = True, True
        self._path = self._used = None
        self._failures, self._error = 0, ""

    def stop(self) -> None:
        self.running = False

    def due(self, now: float) -> bool:
        return self.running and self.goal is not None and (self.wake_now or now >= self.next_due)

    def record(self, generation: int, started: float, seconds: float, result, error: str) -> None:
        if generation != self.generation:
            return  # planned for a goal that has been replaced
        self._seconds = seconds
        if error:
            self._failures += 1
            self._error = error
        else:
            self._path, self._used = result
            if self.frequency <= 0:
                self.running = False
        self.next_due = started + (1.0 / self.frequency if self.frequency > 0 else 0.0)

    def take(self) -> PlanOutcome:
        if self._path is None and not self._failures:
            return NOTHING
        out = PlanOutcome(self._path, self._used, self._failures, self._error, self._seconds)
        self._path = self._used = None
        self._failures, self._error = 0, ""
        return out


def _attempt(plan: Callable, start: Pose2D | None, goal: Pose2D):
    try:
        return (plan(goal) if start is None else plan(start, goal)), ""
    except Exception as e:  # noqa: BLE001 - any planner error is a failed attempt, reported with its text
        return None, str(e) or type(e).__name__


class ImmediatePlanner:
    """Plans synchronously inside ``poll(now, pose)``: ``plan(start, goal) -> (path, goal_used)``."""

    def __init__(self, plan: Callable, frequency: float = 0.0):
        self.plan = plan
        self.s = _Schedule(frequency)

    def start(self, goal: Pose2D) -> None:
        self.s.start(goal)

    def stop(self) -> None:
        self.s.stop()

    def wake(self) -> None:
        self.s.wake_now = True

    def poll(self, now: float, pose: Pose2D | None) -> PlanOutcome:
        s = self.s
        if pose is not None and s.due(now):
            s.wake_now = False
            t0 = time.perf_counter()
            result, error = _attempt(self.plan, pose, s.goal)
            s.record(s.generation, now, time.perf_counter() - t0, result, error)
        return s.take()

    def close(self) -> None:
        pass


class PlannerThread:
    """Plans on its own thread: ``plan(goal) -> (path, goal_used)`` finds the robot pose itself (as
    move_base's makePlan does), ``now()`` is the node's clock (simulated or wall)."""

    def __init__(self, plan: Callable, frequency: float, now: Callable[[], float], name: str = "planner"):
        self.plan, self.now = plan, now
        self.s = _Schedule(frequency)
        self.cond = threading.Condition()
        self._closed = False
        self.thread = threading.Thread(target=self._run, name=name, daemon=True)
        self.thread.start()

    def start(self, goal: Pose2D) -> None:
        with self.cond:
            self.s.start(goal)
            self.cond.notify()

    def stop(self) -> None:
        with self.cond:
            self.s.stop()

    def wake(self) -> None:
        with self.cond:
            if self.s.running and not self.s.wake_now:
                self.s.wake_now = True
                self.cond.notify()

    def poll(self, now: float, pose: Pose2D | None = None) -> PlanOutcome:
        with self.cond:
            return self.s.take()

    def close(self) -> None:
        with self.cond:
            self._closed = True
            self.cond.notify()
        self.thread.join(2.0)

    def _run(self) -> None:
        while True:
            with self.cond:
                while not self._closed and not self.s.due(self.now()):
                    self.cond.wait(0.01)  # short waits: the clock may be simulated
                if self._closed:
                    return
                self.s.wake_now = False
                goal, generation, started = self.s.goal, self.s.generation, self.now()
            t0 = time.perf_counter()
            result, error = _attempt(self.plan, None, goal)
            with self.cond:
                self.s.record(generation, started, time.perf_counter() - t0, result, error)
