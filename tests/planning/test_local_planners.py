"""DWA and trajectory rollout driving a perfect kinematic robot with the tutorial's P3-AT files (their loading:
test_local_planner_files.py)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from planning_helpers import P3AT_FOOTPRINT, drive, free_map, inflate

from common.config import load_params, read_yaml
from common.geometry import Pose2D
from master_side.planning.grid import INSCRIBED, LETHAL, NO_INFORMATION
from master_side.planning.local import (
    DWAPlanner,
    DWAPlannerParams,
    TrajectoryPlanner,
    TrajectoryPlannerParams,
)
from master_side.planning.local.costs import ObstacleCost
from master_side.planning.local.grid_distance import MapGrid
from master_side.planning.local.reachable import reachable_plan
from master_side.planning.local.scoring_context import ScoringContext, angle_diff
from master_side.planning.local.trajectories import Trajectories
from master_side.planning.navfn import NavFn

RES = 0.05


def _p3at(shared_dir, name: str, section: str, cls):
    path = shared_dir / "reference" / "p3at" / name
    data = read_yaml(path)
    return load_params(
        cls, {**data[section], "controller_frequency": 10.0}, source=str(path), section=section
    )


@pytest.fixture
def dwa_params(shared_dir) -> DWAPlannerParams:
    return _p3at(shared_dir, "dwa_planner_ros.yaml", "DWAPlannerROS", DWAPlannerParams)


@pytest.fixture
def tp_params(shared_dir) -> TrajectoryPlannerParams:
    return _p3at(
        shared_dir, "base_local_planner_params.yaml", "TrajectoryPlannerROS", TrajectoryPlannerParams
    )


def _footprint_collisions(grid: np.ndarray, poses: np.ndarray) -> int:
    ctx = ScoringContext(poses[0], np.zeros(3), grid, RES, np.zeros(2), P3AT_FOOTPRINT, poses[:2], poses[1])
    cost = ObstacleCost()
    cost.prepare(ctx)
    return int((cost.score(Trajectories(poses[:, None, :], np.zeros((len(poses), 3)))) < 0).sum())


def _check_run(planner, grid, start: Pose2D, goal: Pose2D, params):
    plan = NavFn().make_plan(grid, RES, (0.0, 0.0), start, goal)
    planner.set_plan(plan)
    reached, poses, cmds, results = drive(planner, start, grid, RES, P3AT_FOOTPRINT)
    assert reached, results[-1].reason
    end = poses[-1]
    assert math.hypot(end[0] - goal.x, end[1] - goal.y) <= params.xy_goal_tolerance + 1e-9
    assert abs(angle_diff(goal.theta, end[2])) <= params.yaw_goal_tolerance
    r, c = (poses[:, 1] / RES).astype(int), (poses[:, 0] / RES).astype(int)
    assert grid[r, c].max() < INSCRIBED
    assert _footprint_collisions(grid, poses) == 0
    final_w = cmds[[res.goal_approach for res in results], 2]
    signs = np.sign(final_w[np.abs(final_w) > 1e-9])
    assert signs.size > 0
    assert np.all(signs == signs[0])
    return poses


def test_dwa_reaches_goal_in_free_space(dwa_params):
    grid = free_map(80, 120)
    _check_run(DWAPlanner(dwa_params), grid, Pose2D(1.0, 2.0, 0.0), Pose2D(4.5, 2.5, 2.0), dwa_params)


def test_dwa_drives_around_an_obstacle_without_touching_lethal_cells(dwa_params):
    grid = free_map(100, 160)
    grid[30:70, 70:75] = LETHAL
    grid = inflate(grid, RES)
    poses = _check_run(
        DWAPlanner(dwa_params), grid, Pose2D(1.0, 2.5, 0.3), Pose2D(6.5, 2.6, -1.5), dwa_params
    )
    assert np.abs(poses[:, 1] - 2.5).max() > 1.0  # went round the wall


def test_trajectory_rollout_reaches_goal_around_an_obstacle(tp_params):
    grid = free_map(100, 160)
    grid[30:70, 70:75] = LETHAL
    grid = inflate(grid, RES)
    params = dataclasses.replace(tp_params, xy_goal_tolerance=0.15, yaw_goal_tolerance=0.1)
    _check_run(TrajectoryPlanner(params), grid, Pose2D(1.0, 2.5, 0.0), Pose2D(6.5, 2.6, 1.5), params)


def test_goal_rotation_slows_down_and_never_reverses(dwa_params):
    planner = DWAPlanner(dwa_params)
    grid = free_map(60, 60)
    goal = Pose2D(1.5, 1.5, 2.5)
    planner.set_plan(np.array([[1.4, 1.5, 0.0], [1.5, 1.5, 2.5]]))
    reached, poses, cmds, results = drive(planner, Pose2D(1.5, 1.5, -0.4), grid, RES, P3AT_FOOTPRINT)
    assert reached
    w = cmds[:, 2]
    assert np.all(w >= -1e-12)  # +2.9 rad is the short way: only positive rotation
    assert abs(w[-1]) <= dwa_params.rot_stopped_vel
    assert abs(angle_diff(goal.theta, poses[-1, 2])) <= dwa_params.yaw_goal_tolerance
    assert np.all(np.abs(np.diff(w)) <= dwa_params.acc_lim_th / 10.0 + 1e-9)  # acceleration limit


def _rotate_with_lag(params, target: float, late_cycle: int, lag: int = 2) -> tuple[Pose2D, list[float]]:
    """Final rotation to ``target`` on a base that applies each command ``lag`` cycles late, with
    control cycle ``late_cycle`` coming one cycle late (the base keeps the old command meanwhile)."""
    planner = TrajectoryPlanner(params)
    dt, acc = planner.limits.sim_period, planner.limits.acc[2]
    planner.set_plan(np.array([[1.5, 1.5, 0.0], [1.5, 1.5, target]]))
    pose, w, queue, cmds = Pose2D(1.5, 1.5, 0.0), 0.0, [0.0] * lag, []
    for cycle in range(300):
        if planner.is_goal_reached(pose, (0.0, 0.0, w)):
            return pose, cmds
        cmds.append(planner.compute_velocity(pose, (0.0, 0.0, w), free_map(60, 60), RES, (0.0, 0.0),
                                             P3AT_FOOTPRINT).cmd[2])
        queue.append(cmds[-1])
        for _ in range(2 if cycle == late_cycle else 1):
            w += float(np.clip(queue[0] - w, -acc * dt, acc * dt))
            pose = Pose2D(pose.x, pose.y, pose.theta + w * dt)
        queue.pop(0)
    pytest.fail(f"goal yaw {target} not reached; commands {np.round(cmds, 3)}")


def test_goal_rotation_absorbs_command_lag_and_a_late_cycle_without_turning_back(tp_params):
    # the tutorial's section 3.6 move_base runs the controller at 6 Hz: a late cycle is 1/6 s more at speed
    p = dataclasses.replace(tp_params, yaw_goal_tolerance=0.05, controller_frequency=6.0)
    for target in (0.6, 1.2, 2.0):
        for late in range(20):
            pose, cmds = _rotate_with_lag(p, target, late)
            assert all(c >= 0.0 for c in cmds), f"to {target}, late cycle {late}: turned back {np.round(cmds, 3)}"
            assert abs(angle_diff(target, pose.theta)) <= p.yaw_goal_tolerance


def test_all_rejected_reports_why_not_moving(dwa_params):
    grid = free_map(60, 60)
    grid[:, 26:] = LETHAL  # wall just in front of the nose, nothing else reachable
    grid[:, :14] = LETHAL
    planner = DWAPlanner(dataclasses.replace(dwa_params, min_vel_x=0.0))
    planner.set_plan(np.array([[1.0, 1.5, 0.0], [2.8, 1.5, 0.0]]))
    res = planner.compute_velocity(
        Pose2D(1.0, 1.5, 0.0), (0.0, 0.0, 0.0), grid, RES, (0.0, 0.0), P3AT_FOOTPRINT
    )
    assert not res.ok
    assert "ObstacleCost" in res.reason
    assert res.cmd == (0.0, 0.0, 0.0)


def test_a_goal_cut_off_on_the_local_costmap_is_said(dwa_params):
    # a wall across the way between the robot and its local goal: the global plan runs through it
    grid = free_map(80, 120)
    grid[:, 70:73] = LETHAL
    grid = inflate(grid, RES)
    planner = DWAPlanner(dwa_params)
    planner.set_plan(np.array([[1.0, 2.0, 0.0], [4.0, 2.0, 0.0], [5.0, 2.0, 0.0]]))
    res = planner.compute_velocity(Pose2D(1.0, 2.0, 0.0), (0.0, 0.0, 0.0), grid, RES, (0.0, 0.0), P3AT_FOOTPRINT)
    assert not res.ok and "mostly by GoalDistance" in res.reason
    assert "the local goal (5.00, 2.00) is cut off from the robot by obstacles on the local costmap" in res.reason
    # the way round the wall runs through cells no sensor has seen (a costmap that tracks the unknown)
    grid = free_map(80, 120)
    grid[:, 70:73] = LETHAL
    grid[5:20, 70:73] = NO_INFORMATION
    res = planner.compute_velocity(Pose2D(1.0, 2.0, 0.0), (0.0, 0.0, 0.0), grid, RES, (0.0, 0.0), P3AT_FOOTPRINT)
    assert "is cut off from the robot by unknown cells on the local costmap" in res.reason, res.reason


def test_the_local_goals_fill_does_not_pass_a_wall_through_the_plans_cells():
    """The path and goal fills run on one graph; the plan's cells are the path fill's targets and expand even in
    a wall (ROS's too). They opened the wall for the goal's fill as well where the plan crossed it a cell at a
    time (a 4-connected row of cells): the goal looked reachable, and DWA wandered in front of the wall."""
    grid = free_map(80, 120)
    grid[:, 70:73] = LETHAL
    grid = inflate(grid, RES)
    plan = np.column_stack((np.linspace(1.0, 5.0, 81), np.full(81, 2.0)))
    mg = MapGrid(grid, RES, (0.0, 0.0))
    path, goal = mg.distances(plan)
    assert path[40, 20] == 0.0 and np.isinf(goal[40, 20])
    assert np.isinf(mg.goal_distance(plan)[40, 20])
    assert goal[40, 110] < np.inf  # beyond the wall, the goal's side


def test_a_cut_off_plan_is_followed_as_far_as_it_is_open_with_cut_off_plan_min_reach(dwa_params):
    """zenav's cut_off_plan_min_reach: the same wall across the plan; the robot drives along the plan while its
    open part reaches at least 0.5 m ahead, and then stops as ROS's planner does at once (no valid command,
    GoalDistance), never in the wall's inscribed band."""
    grid = free_map(80, 120)
    grid[:, 70:73] = LETHAL
    grid = inflate(grid, RES)
    plan = np.column_stack((np.linspace(1.0, 5.0, 81), np.full(81, 2.0), np.zeros(81)))  # navfn's: a pose a cell
    ros = DWAPlanner(dwa_params)
    ros.set_plan(plan)
    assert not ros.compute_velocity(Pose2D(1.0, 2.0, 0.0), (0.0, 0.0, 0.0), grid, RES, (0.0, 0.0), P3AT_FOOTPRINT).ok
    planner = DWAPlanner(dataclasses.replace(dwa_params, cut_off_plan_min_reach=0.5))
    planner.set_plan(plan)
    reached, poses, cmds, results = drive(planner, Pose2D(1.0, 2.0, 0.0), grid, RES, P3AT_FOOTPRINT, max_cycles=300)
    assert not reached
    assert results[0].ok and cmds[0][0] > 0.0, results[0].reason
    stop = next(i for i, r in enumerate(results) if not r.ok)
    assert "the local goal (5.00, 2.00) is cut off" in results[stop].reason, results[stop].reason
    # the open part of the plan ends 0.3 m (the inscribed band, ~6 cells) before the wall at x = 3.5
    front = poses[stop, 0]
    assert 2.2 < front < 3.5 - 0.5 - 0.26 + 0.1, front
    assert all(not r.ok for r in results[stop:stop + 20])  # and stays stopped: patience and recoveries follow
    # not cut off: the same command as ROS's, also where the plan runs on into cells no sensor has seen (ROS's
    # local goal is then the last known cell, which the robot can reach)
    open_grid = inflate(free_map(80, 120), RES)
    open_grid[:, 70:] = NO_INFORMATION
    a = ros.compute_velocity(Pose2D(1.0, 2.0, 0.0), (0.0, 0.0, 0.0), open_grid, RES, (0.0, 0.0), P3AT_FOOTPRINT)
    b = DWAPlanner(dataclasses.replace(dwa_params, cut_off_plan_min_reach=0.5))
    b.set_plan(plan)
    assert b.compute_velocity(Pose2D(1.0, 2.0, 0.0), (0.0, 0.0, 0.0), open_grid, RES, (0.0, 0.0),
                              P3AT_FOOTPRINT).cmd == a.cmd
    ctx = ScoringContext(np.array([1.0, 2.0, 0.0]), np.zeros(3), open_grid, RES, np.zeros(2), P3AT_FOOTPRINT, plan,
                         plan[-1])
    assert reachable_plan(ctx, 0.5) is None
    ctx = ScoringContext(np.array([1.0, 2.0, 0.0]), np.zeros(3), grid, RES, np.zeros(2), P3AT_FOOTPRINT, plan, plan[-1])
    short = reachable_plan(ctx, 0.5)
    assert short is not None and 3.1 < short[-1, 0] < 3.3  # the wall's inscribed band begins 0.26 m before x = 3.5


def test_dwa_samples_respect_the_dynamic_window(dwa_params):
    p = dataclasses.replace(dwa_params, vx_samples=20, vth_samples=20)
    planner = DWAPlanner(p)
    s = planner._samples(np.array([0.3, 0.0, 0.2]))
    dt = 1.0 / p.controller_frequency
    assert len(s) >= 200
    assert np.all(np.abs(s[:, 0] - 0.3) <= p.acc_lim_x * dt + 1e-9)
    assert np.all(np.abs(s[:, 2] - 0.2) <= p.acc_lim_th * dt + 1e-9)
    assert np.all(s[:, 1] == 0.0)  # holonomic_robot: false


def test_from_standstill_the_robot_may_start_turning_in_place_either_way(dwa_params):
    """The window from rest (acc_lim_th 2.0 at 10 Hz: +-0.2 rad/s) is widened to min_rot_vel (0.4) so an
    in-place turn can start; it was widened on the positive side only. A robot beside a wall it had to turn
    away from clockwise had no such sample, and stood until move_base gave up (the mall's exploration)."""
    s = DWAPlanner(dwa_params)._samples(np.zeros(3))
    turns = s[(s[:, 0] == 0.0) & (s[:, 1] == 0.0), 2]
    assert turns.max() == pytest.approx(dwa_params.min_rot_vel)
    assert turns.min() == pytest.approx(-dwa_params.min_rot_vel)


def test_rotation_holds_through_jitter(tp_params):
    """The estimate wanders a few cm across xy_goal_tolerance (not latched, as the tutorial's file) while
    the robot turns in place to the goal yaw: the rotation goes on in one direction and ends at the yaw."""
    p = dataclasses.replace(tp_params, latch_xy_goal_tolerance=False)
    planner = TrajectoryPlanner(p)
    dt, acc, tol = planner.limits.sim_period, planner.limits.acc[2], p.xy_goal_tolerance
    goal = (1.5, 1.5, -2.0)
    planner.set_plan(np.array([[1.2, 1.5, 0.0], [1.35, 1.5, 0.0], [1.5, 1.5, -2.0]]))
    rng, theta, w, cmds = np.random.default_rng(3), 0.0, 0.0, []
    for cycle in range(200):
        r = tol + (0.03 if cycle % 3 == 1 else -0.01) + rng.uniform(-0.005, 0.005)  # in and out of tolerance
        pose = Pose2D(goal[0] - r, goal[1], theta)
        if planner.is_goal_reached(Pose2D(goal[0] - 0.5 * tol, goal[1], theta), (0.0, 0.0, w)):
            break
        cmds.append(planner.compute_velocity(pose, (0.0, 0.0, w), free_map(60, 60), RES, (0.0, 0.0),
                                             P3AT_FOOTPRINT).cmd[2])
        w += float(np.clip(cmds[-1] - w, -acc * dt, acc * dt))
        theta += w * dt
    else:
        pytest.fail(f"goal yaw not reached: {np.round(cmds, 3)}")
    assert all(c <= 1e-12 for c in cmds), f"the rotation turned back: {np.round(cmds, 3)}"
    assert abs(angle_diff(goal[2], theta)) <= p.yaw_goal_tolerance


def test_dwa_predicts_a_turn_about_the_bases_turning_centre(dwa_params):
    """A skid-steered base that pivots behind base_link (rotation_center_x < 0) carries base_link round
    that point: DWA's predicted poses follow the circle about it, while the commands it chooses from stay
    the samples (no sideways velocity is ever commanded). 0, the default, is ROS's turn about base_link."""
    cx, w = -0.12, 0.8
    samples = np.array([[0.0, 0.0, w], [0.3, 0.0, 0.0]])
    for centre in (0.0, cx):
        planner = DWAPlanner(dataclasses.replace(dwa_params, rotation_center_x=centre))
        trajs = planner._simulate(np.zeros(3), np.zeros(3), samples)
        np.testing.assert_array_equal(trajs.vels, samples)
        turn = trajs.row(0)
        th = turn[:, 2]
        # base_link at (I - R(th)) c for a turn about c = (centre, 0) from the origin
        np.testing.assert_allclose(turn[:, 0], centre - centre * np.cos(th), atol=0.01)
        np.testing.assert_allclose(turn[:, 1], -centre * np.sin(th), atol=0.01)
        np.testing.assert_allclose(trajs.row(1)[:, 1], 0.0, atol=1e-12)  # a straight drive is not moved
    assert turn[-1, 1] > 0.1  # with the pivot 0.12 m behind, a 1.4 rad left turn moves base_link 0.12 m left
