"""TrajectoryPlanner's escape: wedged with its padded footprint on an obstacle, it backs up if the robot's
own outline stays clear (ROS backs up blindly); with the obstacle behind, it does not back into it."""

from __future__ import annotations

import numpy as np

from common.geometry import Pose2D
from master_side.costmap.footprint import pad_footprint
from master_side.planning.grid import LETHAL
from master_side.planning.local import TrajectoryPlanner, TrajectoryPlannerParams

RES = 0.05
BARE = np.array([[-0.25, -0.2], [-0.25, 0.2], [0.25, 0.2], [0.25, -0.2]])
PADDING = 0.1


def _planner() -> TrajectoryPlanner:
    p = TrajectoryPlanner(TrajectoryPlannerParams(holonomic_robot=False, escape_vel=-0.2, min_vel_x=0.1,
                                                  max_vel_x=0.5, controller_frequency=10.0))
    p.footprint_padding = PADDING
    return p


def _wedged(wall_x: float) -> tuple[np.ndarray, TrajectoryPlanner]:
    """A wall across x = wall_x; the robot at (2, 2) facing +x, its padded nose 2-3 cm into the wall."""
    grid = np.zeros((80, 80), np.uint8)
    grid[:, int(wall_x / RES)] = LETHAL
    planner = _planner()
    xs = np.linspace(2.0, 3.8, 40)
    planner.set_plan(np.column_stack((xs, np.full_like(xs, 2.0), np.zeros_like(xs))))
    return grid, planner


def test_wedged_by_its_padding_it_backs_up_along_its_own_outline():
    grid, planner = _wedged(2.32)  # the padded nose (x + 0.35) reaches the wall cell, the bare one (0.25) not
    grid[int(2.27 / RES), int(1.72 / RES)] = LETHAL  # a post by the rear-left corner, inside the padding:
    # backing up brings the centre nearer to it (so the padded check refuses), the bare outline passes it
    fp = pad_footprint(BARE, PADDING)
    planner.footprint_padding = 0.0
    r = planner.compute_velocity(Pose2D(2.0, 2.0, 0.0), (0.0, 0.0, 0.0), grid, RES, (0.0, 0.0), fp)
    assert not r.ok, r  # with the padded footprint alone there is no way out
    planner.footprint_padding = PADDING
    r = planner.compute_velocity(Pose2D(2.0, 2.0, 0.0), (0.0, 0.0, 0.0), grid, RES, (0.0, 0.0), fp)
    assert r.ok and r.cmd[0] < 0.0 and "escaping" in r.reason


def test_it_does_not_back_into_an_obstacle_behind_it():
    grid, planner = _wedged(2.32)
    grid[:, int(1.72 / RES)] = LETHAL  # a wall right behind too
    r = planner.compute_velocity(Pose2D(2.0, 2.0, 0.0), (0.0, 0.0, 0.0), grid, RES, (0.0, 0.0),
                                 pad_footprint(BARE, PADDING))
    assert not (r.ok and r.cmd[0] < 0.0), r
