"""Compile every numba kernel once, so no node pays the compile on its first plan or scan.

``python -m deploy.warm_kernels`` (run by ``deploy/install.sh`` and ``zenav fleet install``): small but
real calls through the planners' and SLAM's public entry points, so the kernels are compiled for the
argument types the nodes use and land in numba's on-disk cache (``__pycache__`` beside each module, or
the user's cache when that is read-only). Later processes load them in milliseconds; a cold compile
costs a few seconds per component. Prints one line per component.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from common.geometry import Pose2D


def _grid() -> np.ndarray:
    """A 2 m x 2 m, 0.025 m local costmap with one inflated box (the outline and lethal paths run)."""
    from scipy import ndimage

    from master_side.planning.grid import INSCRIBED, LETHAL

    g = np.zeros((80, 80), np.uint8)
    g[50:56, 40:46] = LETHAL
    d = ndimage.distance_transform_edt(g < LETHAL) * 0.025
    infl = np.where(d <= 0.254, INSCRIBED, np.where(d <= 0.35, 252 * np.exp(-10 * (d - 0.254)), 0))
    return np.maximum(g, infl.astype(np.uint8))


def _planners() -> None:
    from master_side.planning.local import DWAPlanner, TrajectoryPlanner
    from master_side.planning.navfn import NavFn, NavfnParams

    grid = _grid()
    for p in (NavfnParams(), NavfnParams(use_dijkstra=False), NavfnParams(use_quadratic=False)):
        NavFn(p).make_plan(grid, 0.025, (0.0, 0.0), Pose2D(0.3, 0.3, 0.0), Pose2D(1.7, 1.7, 0.0))
    square = np.array([[0.25, -0.25], [0.25, 0.25], [-0.25, 0.25], [-0.25, -0.25]])
    xs = np.linspace(0.3, 1.9, 30)
    plan = np.column_stack((xs, 1.0 + 0.2 * np.sin(xs), np.zeros_like(xs)))
    for planner in (DWAPlanner(), TrajectoryPlanner()):
        planner.set_plan(plan)
        for x in (0.3, 0.5):
            planner.compute_velocity(Pose2D(x, 1.0, 0.1), (0.2, 0.0, 0.1), grid, 0.025, (0.0, 0.0), square)


COMPONENTS = {"planners (navfn, DWA, trajectory rollout)": _planners}


def main() -> int:
    for name, fn in COMPONENTS.items():
        t0 = time.monotonic()
        fn()
        print(f"zenav kernels: {name} ready ({time.monotonic() - t0:.1f} s)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
