"""navfn in a child process, so that global planning never holds the control loop's interpreter lock.

move_base plans on its own thread (``planner_thread``), as ROS does; in Python a thread still shares
one interpreter lock with the control cycle, and a 30 ms plan on an 800 x 800 costmap every 100 ms
stretched control cycles to 20-40 ms. The thread now hands each plan to this worker (a freshly
spawned interpreter: forking a process that runs Zenoh's threads is not safe) and waits on the pipe
with the lock released, and at a lower OS priority (a 20 Hz planner_frequency on two cores otherwise
takes CPU the control loop needs). Planner errors come back as the same exceptions.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import threading

import numpy as np

from common.geometry import Pose2D
from master_side.planning.navfn import NavFn, NavfnParams
from master_side.planning.warmup import warm_navfn

PLANNER_NICENESS = 10  # os.nice increment of the worker: on a busy robot PC planning yields to control


def _serve(conn, params: NavfnParams) -> None:
    with contextlib.suppress(OSError):  # background work: the control loop and the sensors come first
        os.nice(PLANNER_NICENESS)
    warm_navfn()  # numba's start and the kernel loads happen now, not in the first plan
    planner = NavFn(params)
    while True:
        try:
            job = conn.recv()
        except (EOFError, OSError):
            return
        if job is None:
            return
        grid, resolution, origin, start, goal, tolerance = job
        try:
            path = planner.make_plan(grid, resolution, origin, Pose2D(*start), Pose2D(*goal), tolerance)
            used = planner.last_goal_used
            conn.send((True, (path, None if used is None else (used.x, used.y, used.theta))))
        except Exception as e:  # noqa: BLE001 - any planner error goes back to the caller as it was
            conn.send((False, e))


class NavfnProcess:
    """``make_plan(grid, resolution, origin, start, goal, tolerance=None) -> path`` run in a worker
    process; ``last_goal_used`` as NavFn's. One plan at a time (callers are serialised)."""

    def __init__(self, params: NavfnParams):
        ctx = multiprocessing.get_context("spawn")
        self._conn, child = ctx.Pipe()
        self._proc = ctx.Process(target=_serve, args=(child, params), name="navfn", daemon=True)
        self._proc.start()
        child.close()
        self._lock = threading.Lock()
        self.last_goal_used: Pose2D | None = None

    def make_plan(self, grid: np.ndarray, resolution: float, origin, start: Pose2D, goal: Pose2D,
                  tolerance: float | None = None) -> np.ndarray:
        job = (np.ascontiguousarray(grid), float(resolution), (float(origin[0]), float(origin[1])),
               (start.x, start.y, start.theta), (goal.x, goal.y, goal.theta), tolerance)
        with self._lock:
            if not self._proc.is_alive():
                raise RuntimeError(f"the navfn worker process exited (code {self._proc.exitcode})")
            self._conn.send(job)
            ok, payload = self._conn.recv()
        if not ok:
            raise payload
        path, used = payload
        self.last_goal_used = None if used is None else Pose2D(*used)
        return path

    def close(self) -> None:
        try:
            with self._lock:
                self._conn.send(None)
        except (OSError, ValueError):
            pass
        self._proc.join(2.0)
        if self._proc.is_alive():
            self._proc.kill()
        self._conn.close()
