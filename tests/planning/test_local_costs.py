"""Scoring functions and the scored sampling planner on hand-built tiny scenes."""

from __future__ import annotations

import numpy as np
from planning_helpers import P3AT_FOOTPRINT, free_map

from master_side.planning.grid import LETHAL, NO_INFORMATION
from master_side.planning.local.costs import (
    GoalAlign,
    GoalDistance,
    ObstacleCost,
    Oscillation,
    PathAlign,
    PathDistance,
    Twirling,
)
from master_side.planning.local.scoring import ScoredSamplingPlanner
from master_side.planning.local.scoring_context import ScoringContext
from master_side.planning.local.trajectories import Trajectories, simulate

RES = 0.05


def _ctx(grid, pose=(1.0, 1.5, 0.0), plan=None, footprint=P3AT_FOOTPRINT) -> ScoringContext:
    if plan is None:
        xs = np.linspace(1.0, 2.8, 40)
        plan = np.column_stack((xs, np.full_like(xs, 1.5), np.zeros_like(xs)))
    return ScoringContext(
        np.array(pose, float),
        np.zeros(3),
        grid,
        RES,
        np.zeros(2),
        np.asarray(footprint, float),
        plan,
        plan[-1],
    )


def _straight(samples, pose=(1.0, 1.5, 0.0), t=1.0) -> Trajectories:
    return simulate(np.array(pose, float), np.zeros(3), np.array(samples, float), t, 20)


def test_obstacle_cost_rejects_trajectory_through_a_wall_and_accepts_one_beside_it():
    grid = free_map(60, 60)
    grid[20:40, 40:42] = LETHAL  # wall across y 1.0..2.0 at x = 2.0..2.1
    trajs = _straight([[1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])  # through the wall / standing still
    cost = ObstacleCost()
    cost.prepare(_ctx(grid))
    s = cost.score(trajs)
    assert s[0] < 0
    assert s[1] >= 0


def test_obstacle_cost_checks_the_footprint_not_only_the_centre():
    grid = free_map(60, 60)
    grid[:, 27] = LETHAL  # x = 1.35..1.40: the nose (x + 0.33) of a robot at x = 1.05 reaches it
    cost = ObstacleCost()
    cost.prepare(_ctx(grid))
    near = _straight([[0.0, 0.0, 0.0]], pose=(1.05, 1.5, 0.0))
    far = _straight([[0.0, 0.0, 0.0]], pose=(0.9, 1.5, 0.0))
    assert grid[30, 21] == 0  # the centre cell itself is free
    assert cost.score(near)[0] < 0
    assert cost.score(far)[0] >= 0


def test_obstacle_cost_rejects_unknown_and_off_map_and_reports_max_cost():
    grid = free_map(60, 60)
    grid[:, 50:] = NO_INFORMATION
    grid[20:40, 30:32] = 100
    cost = ObstacleCost()
    cost.prepare(_ctx(grid))
    s = cost.score(_straight([[1.5, 0.0, 0.0], [0.0, 0.0, 0.0], [0.5, 0.0, 0.0]], t=1.0))
    assert s[0] < 0  # runs into unknown space
    assert s[1] == 0  # standing still in free space
    assert s[2] == 100  # crosses the cost-100 band
    off = _straight([[-2.0, 0.0, 0.0]])
    assert cost.score(off)[0] < 0


def test_path_distance_prefers_the_trajectory_along_the_path():
    grid = free_map(60, 60)
    ctx = _ctx(grid)
    trajs = _straight([[0.5, 0.0, 0.0], [0.5, 0.0, 0.6], [0.5, 0.0, -0.6]])
    cost = PathDistance()
    assert cost.prepare(ctx)
    s = cost.score(trajs)
    assert s[0] < 0.05
    assert s[1] > s[0] + 0.05
    assert s[2] > s[0] + 0.05


def test_goal_distance_prefers_progress_toward_the_goal():
    ctx = _ctx(free_map(60, 60))
    cost = GoalDistance()
    cost.prepare(ctx)
    s = cost.score(_straight([[0.5, 0.0, 0.0], [0.1, 0.0, 0.0], [-0.1, 0.0, 0.0]]))
    assert s[0] < s[1] < s[2]


def test_alignment_costs_prefer_facing_along_the_path():
    ctx = _ctx(free_map(60, 60), pose=(1.0, 1.5, 0.8))  # robot turned 0.8 rad away from the path
    trajs = _straight([[0.0, 0.0, -0.8], [0.0, 0.0, 0.8]], pose=(1.0, 1.5, 0.8))
    for cost in (PathAlign(forward_point_distance=0.325), GoalAlign(forward_point_distance=0.325)):
        assert cost.prepare(ctx)
        s = cost.score(trajs)
        assert s[0] < s[1]


def test_path_alignment_switches_off_near_the_goal_but_goal_front_stays():
    plan = np.array([[1.0, 1.5, 0.0], [1.1, 1.5, 0.0]])
    ctx = _ctx(free_map(60, 60), plan=plan)
    assert not PathAlign(forward_point_distance=0.325).prepare(ctx)
    assert GoalAlign(forward_point_distance=0.325).prepare(ctx)  # dwa_planner.cpp keeps goal_front


def test_oscillation_blocks_reversing_rotation_until_the_robot_turned_enough():
    osc = Oscillation(reset_dist=0.05, reset_angle=0.2)
    ctx = _ctx(free_map(60, 60))
    trajs = _straight([[0.0, 0.0, 0.5], [0.0, 0.0, -0.5], [0.2, 0.0, 0.0]])
    osc.update(np.array([0.0, 0.0, 0.5]), ctx.pose)
    assert not osc.prepare(ctx)  # no reversal seen yet: nothing restricted
    osc.update(np.array([0.0, 0.0, -0.5]), ctx.pose)  # reversed: now only negative rotation allowed
    assert osc.prepare(ctx)
    np.testing.assert_array_equal(osc.score(trajs) < 0, [True, False, False])
    turned = _ctx(free_map(60, 60), pose=(1.0, 1.5, -0.3))
    assert not osc.prepare(turned)  # turned more than reset_angle: flags cleared


def test_twirling_penalises_rotation():
    s = Twirling().score(_straight([[0.3, 0.0, 0.0], [0.3, 0.0, 0.5]]))
    assert s[0] < s[1]


def test_scored_sampling_picks_the_cheapest_and_names_the_rejecting_cost():
    grid = free_map(60, 60)
    grid[:, 24:26] = LETHAL  # wall right in front of the robot (x = 1.2..1.3)
    ctx = _ctx(grid, pose=(0.7, 1.5, 0.0))
    planner = ScoredSamplingPlanner([ObstacleCost(0.01), PathDistance(16.0), GoalDistance(12.0)])
    trajs = _straight([[0.5, 0.0, 0.0], [0.5, 0.0, 0.3]], pose=(0.7, 1.5, 0.0))
    res = planner.score(trajs, ctx)
    assert res.best == -1
    assert "ObstacleCost" in res.reason
    free_ctx = _ctx(free_map(60, 60), pose=(0.7, 1.5, 0.0))
    res = planner.score(trajs, free_ctx)
    assert res.best == 0
    assert res.reason == ""


def test_obstacle_cost_lets_a_robot_touching_an_obstacle_back_away_but_not_push_on():
    grid = free_map(60, 60)
    grid[:, 27] = LETHAL  # the nose of a robot at x = 1.05 touches it (see the test above)
    cost = ObstacleCost()
    cost.prepare(_ctx(grid))
    trajs = _straight([[-0.3, 0.0, 0.0], [0.0, 0.0, 0.0], [0.2, 0.0, 0.0]], pose=(1.05, 1.5, 0.0))
    s = cost.score(trajs)
    assert s[0] >= 0  # backing away from the contact is allowed
    assert s[1] < 0 and s[2] < 0  # staying in contact or pushing on is not


def test_an_unseen_cell_published_at_a_cost_is_scored_not_rejected_and_the_seen_way_wins():
    """The local costmap's unseen_cost (p3at_zenav/local_costmap_slam.yaml): a thin unseen strip ahead
    and left, as a wall's end the camera never showed, costs the arc that sweeps it, which is not refused;
    the straight drive that keeps clear of it costs less."""
    grid = free_map(60, 60)
    grid[36:38, 26:34] = 250  # y 1.80..1.90, x 1.30..1.70: unseen (published at 250)
    trajs = _straight([[0.4, 0.0, 0.6], [0.4, 0.0, 0.0]])  # arcing left over it / straight
    cost = ObstacleCost()
    cost.prepare(_ctx(grid))
    s = cost.score(trajs)
    assert s[0] == 250 and 0 <= s[1] < 250
    grid[36:38, 26:34] = NO_INFORMATION  # as ROS publishes it: the arc refused
    cost.prepare(_ctx(grid))
    assert cost.score(trajs)[0] < 0
