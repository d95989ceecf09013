"""MRPB's office02 (a map no one here made, ``../shared/datasets/mrpb``) in one process: the simulated P3-AT
with its planar laser, zenav's best P3-AT configuration (p3at_zenav.yaml) on the office's map.

The two legs that start facing away from the goal: with the tutorial's files DWA backed up at 0.55 m/s
(min_vel_x -0.55) where the forward-looking laser sees nothing, into a wall (issue 32). zenav's files back
up at 0.1 m/s at most (so DWA turns toward the path instead) and keep the known walls in the local costmap:
every leg reaches its goal with no collision. The same legs over the bus are in the README ("Buildings")."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from common.geometry import Pose2D
from common.messages import GoalStatus
from deploy.stack.inproc import InProcessStack

REPO = Path(__file__).resolve().parents[2]
ROBOT = REPO / "robot_side" / "config" / "p3at_sim_laser.yaml"
MASTER = REPO / "master_side" / "config" / "p3at_zenav.yaml"
XY_TOL = 0.3  # the tutorial's xy_goal_tolerance

LEGS = {  # MRPB test 1 reversed, and test 1's goal -> test 3's goal -> test 2's goal (the issue's order)
    "test1_reverse": ((13.059, 1.702, 0.0), (-12.547, 8.542, 0.0)),
    "goal3_to_goal2": ((6.275, 8.438, 3.142), (-12.364, -8.959, 3.142)),
}


@pytest.mark.parametrize("leg", sorted(LEGS))
def test_p3at_zenav_crosses_office02_from_a_start_facing_away(shared_dir, leg):
    office = shared_dir / "datasets" / "mrpb" / "map10cm" / "office02" / "map.yaml"
    start, goal = LEGS[leg]
    stack = InProcessStack(office, ROBOT, MASTER, start=start, map_file=office)
    out = stack.goto(Pose2D(*goal), time_limit_s=200.0)
    assert out.collisions == 0, f"collision at {stack.sim.base.contact}; {stack.events[-5:]}"
    assert out.status == GoalStatus.SUCCEEDED, f"{out.reason}; {stack.events[-5:]}"
    assert math.hypot(out.truth.x - goal[0], out.truth.y - goal[1]) <= XY_TOL + 0.05
    assert min(v for _, v, _ in out.cmds) >= -0.1 - 1e-9  # it never backed up faster than 0.1 m/s
