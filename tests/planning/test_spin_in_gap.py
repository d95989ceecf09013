"""The BARN spin: in front of a tight gap, ROS's trajectory planner scores turning in place (free
footprint) below every trajectory into the gap (outline in the inflated zone, occdist_scale 0.1), so it
would turn forever. zenav's planner leaves in-place rotation out after a full revolution without
progress, and move_base counts a longer in-place spin as a failed controller (recovery)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from planning_helpers import inflate

from common.config import read_yaml
from common.geometry import Pose2D, footprint_radii
from master_side.move_base.params import MoveBaseParams
from master_side.move_base.planner_thread import ImmediatePlanner
from master_side.move_base.state_machine import ControlResult, MoveBaseMachine, State
from master_side.planning.grid import LETHAL
from master_side.planning.local import TrajectoryPlanner, TrajectoryPlannerParams

RES = 0.05
BARN = Path(__file__).resolve().parents[2] / "master_side" / "config" / "barn" / "base_local_planner_params.yaml"
FOOTPRINT = np.array([[-0.31, -0.265], [-0.31, 0.265], [0.31, 0.265], [0.31, -0.265]])  # BARN's, padded


def _gap_scene() -> tuple[np.ndarray, np.ndarray]:
    """Two cylinder clusters 0.9 m apart (centres) across y = 2.0, a plan straight through the gap."""
    grid = np.zeros((80, 80), np.uint8)
    yy, xx = np.mgrid[0:80, 0:80]
    cx, cy = (xx + 0.5) * RES, (yy + 0.5) * RES
    for x0 in (1.05, 2.15):
        for dx in (-0.3, -0.15, 0.0, 0.15, 0.3):
            if (x0 < 1.6 and dx > 0.0) or (x0 > 1.6 and dx < 0.0):
                continue
            grid[np.hypot(cx - (x0 + dx), cy - 2.0) <= 0.075 + RES / 2] = LETHAL
    inscribed = footprint_radii(FOOTPRINT)[0]
    grid = inflate(grid, RES, inscribed=inscribed, radius=0.30, scaling=10.0)
    ys = np.linspace(0.9, 3.8, 60)
    plan = np.column_stack((np.full_like(ys, 1.6), ys, np.full_like(ys, math.pi / 2)))
    return grid, plan


def _barn_planner() -> TrajectoryPlanner:
    data = read_yaml(BARN)["TrajectoryPlannerROS"]
    data.pop("publish_cost_grid_pc")
    return TrajectoryPlanner(TrajectoryPlannerParams(**{k: v for k, v in data.items()
                                                        if k in TrajectoryPlannerParams.__dataclass_fields__}))


def _drive(planner, grid, plan, seconds: float) -> tuple[np.ndarray, float]:
    """Kinematic robot following the commands; returns (poses, in-place rotation before any translation)."""
    planner.set_plan(plan)
    pose, vel, dt = Pose2D(1.6, 1.4, 0.5), (0.0, 0.0, 0.0), planner.limits.sim_period
    poses, spin_before_moving, moved = [pose.as_array()], 0.0, False
    for _ in range(int(seconds / dt)):
        r = planner.compute_velocity(pose, vel, grid, RES, (0.0, 0.0), FOOTPRINT)
        vel = r.cmd
        c, s = math.cos(pose.theta), math.sin(pose.theta)
        pose = Pose2D(pose.x + vel[0] * c * dt, pose.y + vel[0] * s * dt, pose.theta + vel[2] * dt)
        moved |= abs(vel[0]) > 0.01
        if not moved:
            spin_before_moving += abs(vel[2]) * dt
        poses.append(pose.as_array())
    return np.array(poses), spin_before_moving


def test_ros_scoring_alone_spins_in_front_of_the_gap():
    grid, plan = _gap_scene()
    planner = _barn_planner()
    planner._spun = lambda pose, footprint: False  # ROS's TrajectoryPlanner: no check on in-place turning
    poses, spin = _drive(planner, grid, plan, 30.0)
    assert spin > 4 * math.pi  # turned two revolutions and more without ever driving
    assert poses[:, 1].max() < 1.45


def test_trajectory_planner_stops_spinning_and_drives_through_the_gap():
    grid, plan = _gap_scene()
    poses, spin = _drive(_barn_planner(), grid, plan, 30.0)
    assert spin < 2 * math.pi + 0.5  # at most one revolution in place
    assert poses[:, 1].max() > 2.6  # through the gap (cylinders at y = 2.0)
    r, c = (poses[:, 1] / RES).astype(int), (poses[:, 0] / RES).astype(int)
    assert (grid[r, c] < 253).all()  # the centre never entered an inscribed cell


class _Spinner:
    """A local planner that always answers 'turn in place' (a valid command)."""

    def set_plan(self, path):
        pass

    def compute(self, pose, vel):
        return ControlResult((0.0, 0.0, 0.5), True)

    def goal_reached(self, pose, vel):
        return False


def test_move_base_sends_an_endless_in_place_spin_to_recovery():
    class Record:
        name, started = "record", []

        def enabled(self, params):
            return True

        def start(self, now):
            self.started.append(now)

        def step(self, now, pose, vel):
            return (0.0, 0.0, 0.0), True

    rec = Record()
    params = MoveBaseParams(controller_patience=1e6)
    plan = ImmediatePlanner(lambda s, g: (np.array([[s.x, s.y, 0.0], [g.x, g.y, 0.0]]), g), params.planner_frequency)
    m = MoveBaseMachine(params, plan, _Spinner(), [rec])
    m.set_goal("g", Pose2D(3.0, 0.0, 0.0), 0.0)
    yaw, t = 0.0, 0.0
    while not rec.started and t < 60.0:
        d = m.tick(t, Pose2D(0.0, 0.0, yaw), (0.0, 0.0, 0.5))
        yaw += d.cmd[2] * 0.05
        t += 0.05
    assert rec.started, "move_base let the robot spin in place for a minute"
    assert 4 * math.pi - 0.2 < yaw < 4 * math.pi + 1.0  # two revolutions (max_in_place_rotation)
    assert m.state in (State.CLEARING, State.PLANNING, State.CONTROLLING)
