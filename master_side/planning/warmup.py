"""Load (or compile) the planners' numba kernels before the first real plan or control cycle.

The first kernel call of a process starts numba (about 0.5 s) and loads each kernel from the on-disk
cache, or compiles it (seconds) when the cache is cold. A control loop must not pay that inside its
first cycle, so move_base calls ``warm_local_planners`` at start and its navfn worker ``warm_navfn``;
``deploy.warm_kernels`` calls both at install time to fill the cache. Small but real calls through the
public entry points, so the kernels get the argument types the nodes use.
"""

from __future__ import annotations

import numpy as np

from common.geometry import Pose2D
from master_side.planning.grid import INSCRIBED, LETHAL

RES = 0.025


def _grid() -> np.ndarray:
    """A 2 m x 2 m local costmap with one inflated box (the outline and lethal code paths run)."""
    from scipy import ndimage

    g = np.zeros((80, 80), np.uint8)
    g[50:56, 40:46] = LETHAL
    d = ndimage.distance_transform_edt(g < LETHAL) * RES
    infl = np.where(d <= 0.254, INSCRIBED, np.where(d <= 0.35, 252 * np.exp(-10 * (d - 0.254)), 0))
    return np.maximum(g, infl.astype(np.uint8))


def warm_navfn() -> None:
    from master_side.planning.navfn import NavFn, NavfnParams

    grid = _grid()
    for p in (NavfnParams(), NavfnParams(use_dijkstra=False), NavfnParams(use_quadratic=False)):
        NavFn(p).make_plan(grid, RES, (0.0, 0.0), Pose2D(0.3, 0.3, 0.0), Pose2D(1.7, 1.7, 0.0))


def warm_local_planners() -> None:
    from master_side.planning.local import DWAPlanner, TrajectoryPlanner

    grid = _grid()
    square = np.array([[0.25, -0.25], [0.25, 0.25], [-0.25, 0.25], [-0.25, -0.25]])
    xs = np.linspace(0.3, 1.9, 30)
    plan = np.column_stack((xs, 1.0 + 0.2 * np.sin(xs), np.zeros_like(xs)))
    for planner in (DWAPlanner(), TrajectoryPlanner()):
        planner.set_plan(plan)
        for x in (0.3, 0.5):
            planner.compute_velocity(Pose2D(x, 1.0, 0.1), (0.2, 0.0, 0.1), grid, RES, (0.0, 0.0), square)
