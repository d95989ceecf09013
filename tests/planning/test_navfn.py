"""navfn: potential + gradient path on tiny hand-built costmaps."""

from __future__ import annotations

import math

import numpy as np
import pytest
from planning_helpers import free_map, inflate

from common.config import ConfigError, load_params
from common.geometry import Pose2D
from master_side.planning.errors import (
    GoalOccupied,
    GoalOutsideMap,
    NoPath,
    PlannerTimeout,
    StartOccupied,
    StartOutsideMap,
)
from master_side.planning.grid import INSCRIBED, LETHAL, NO_INFORMATION
from master_side.planning.navfn import NavFn, NavfnParams, path_length

RES = 0.05


def _cells_on(grid: np.ndarray, path: np.ndarray, res: float = RES) -> np.ndarray:
    """Costmap values under densely resampled path points."""
    seg = np.diff(path[:, :2], axis=0)
    pts = np.vstack([path[i, :2] + seg[i] * t for i in range(len(seg)) for t in np.linspace(0, 1, 5)])
    r, c = np.floor(pts[:, 1] / res).astype(int), np.floor(pts[:, 0] / res).astype(int)
    return grid[r, c]


@pytest.mark.parametrize("goal", [(4.0, 0.6), (4.0, 2.2), (2.1, 4.4), (0.7, 4.2)])
def test_free_space_path_is_straight_within_two_percent(goal):
    grid = free_map(100, 100)
    start = Pose2D(0.52, 0.61, 0.0)
    path = NavFn().make_plan(grid, RES, (0.0, 0.0), start, Pose2D(*goal, 0.7))
    euclid = math.hypot(goal[0] - start.x, goal[1] - start.y)
    assert path_length(path) <= 1.02 * euclid
    assert path_length(path) >= euclid - 1e-9
    np.testing.assert_allclose(path[0, :2], [start.x, start.y])
    np.testing.assert_allclose(path[-1], [goal[0], goal[1], 0.7])
    # heading of interior poses points along the path
    d = np.diff(path[:, :2], axis=0)
    np.testing.assert_allclose(path[:-1, 2], np.arctan2(d[:, 1], d[:, 0]))


def test_path_detours_around_a_wall_without_touching_lethal_or_inscribed_cells():
    grid = free_map(80, 80)
    grid[10:70, 38:42] = LETHAL
    grid = inflate(grid, RES)
    start, goal = Pose2D(0.8, 2.0, 0.0), Pose2D(3.2, 2.0, 0.0)
    path = NavFn().make_plan(grid, RES, (0.0, 0.0), start, goal)
    assert _cells_on(grid, path).max() < INSCRIBED
    straight = goal.x - start.x
    assert path_length(path) > straight + 1.0  # had to go round the end of the wall
    assert path_length(path) < 3 * straight


def test_no_path_when_the_goal_is_walled_off():
    grid = free_map(40, 40)
    grid[:, 20] = LETHAL
    with pytest.raises(NoPath):
        NavFn().make_plan(grid, RES, (0.0, 0.0), Pose2D(0.3, 1.0), Pose2D(1.7, 1.0))


def test_no_path_says_how_small_the_starts_region_is_and_what_closes_it():
    """A robot boxed in by inflation (a ring of inscribed cells inside lethal walls): the error names the
    passable area reached from the start, the kinds of cells closing it and the nearest of them."""
    grid = free_map(60, 80)
    grid[10:31, 10] = grid[10:31, 30] = LETHAL
    grid[10, 10:31] = grid[30, 10:31] = LETHAL
    grid[11:30, 11] = grid[11:30, 29] = INSCRIBED
    grid[11, 11:30] = grid[29, 11:30] = INSCRIBED
    with pytest.raises(NoPath) as e:
        NavFn().make_plan(grid, RES, (0.0, 0.0), Pose2D(1.0, 1.0), Pose2D(3.5, 2.5))
    assert "the start's passable region is 0.72 m²" in str(e.value)  # 17 x 17 cells inside the ring
    assert "closed by 72 inscribed;" in str(e.value)
    assert "; the nearest, inscribed, at (1.03, 0.58);" in str(e.value)  # the ring's cell below the start
    assert str(e.value).endswith("first crosses 2 impassable cell(s) (1 lethal, 1 inscribed) from (1.48, 1.03) to "
                                 "(1.53, 1.03)")  # the box's right side, towards the goal


def test_no_path_counts_unknown_cells_that_close_the_way_without_allow_unknown():
    grid = free_map(40, 40)
    grid[:, 20] = NO_INFORMATION
    why = r"region is 2\.00 m², closed by 40 unknown; the nearest, unknown, at \(1\.03, 1\.03\); .* crosses 1 "
    with pytest.raises(NoPath, match=why):
        NavFn(NavfnParams(allow_unknown=False)).make_plan(grid, RES, (0.0, 0.0), Pose2D(0.3, 1.0), Pose2D(1.7, 1.0))


def test_no_path_names_where_inflation_closed_a_corridor_rather_than_a_wall():
    """A wall with a doorway that inflation (or a phantom mark's inflation) has closed: the cheapest way
    through is the doorway's inscribed cells, not the wall's lethal ones."""
    grid = free_map(100, 200)
    grid[:, 100:104] = LETHAL
    grid[40:48, 100:104] = INSCRIBED  # the doorway, y 2.0 to 2.4 m
    with pytest.raises(NoPath) as e:
        NavFn().make_plan(grid, RES, (0.0, 0.0), Pose2D(1.0, 1.0), Pose2D(9.0, 4.0))
    assert str(e.value).endswith("first crosses 4 impassable cell(s) (4 inscribed) from (5.03, 2.02) to (5.18, 2.02)")


def test_start_in_lethal_cell_raises_start_occupied():
    grid = free_map(40, 40)
    grid[20, 10] = LETHAL
    with pytest.raises(StartOccupied):
        NavFn().make_plan(grid, RES, (0.0, 0.0), Pose2D(10.5 * RES, 20.5 * RES), Pose2D(1.5, 1.5))


def test_start_or_goal_off_the_map():
    grid = free_map(40, 40)
    with pytest.raises(StartOutsideMap):
        NavFn().make_plan(grid, RES, (0.0, 0.0), Pose2D(-1.0, 0.5), Pose2D(1.5, 1.5))
    with pytest.raises(GoalOutsideMap):
        NavFn().make_plan(grid, RES, (0.0, 0.0), Pose2D(0.5, 0.5), Pose2D(5.0, 1.5))


@pytest.mark.parametrize("value", [INSCRIBED, LETHAL])
def test_goal_in_obstacle_without_tolerance_raises_goal_occupied(value):
    grid = free_map(40, 40)
    grid[18:23, 28:33] = value
    with pytest.raises(GoalOccupied):
        NavFn().make_plan(grid, RES, (0.0, 0.0), Pose2D(0.3, 1.0), Pose2D(30.5 * RES, 20.5 * RES))


def test_goal_in_obstacle_uses_nearest_reachable_cell_within_tolerance():
    grid = free_map(40, 40)
    grid[18:23, 28:33] = LETHAL  # 5x5 block, goal in its centre
    goal = Pose2D(30.5 * RES, 20.5 * RES, 1.0)
    nf = NavFn(NavfnParams(default_tolerance=0.2))
    path = nf.make_plan(grid, RES, (0.0, 0.0), Pose2D(0.3, 1.0), goal)
    end = path[-1]
    assert math.hypot(end[0] - goal.x, end[1] - goal.y) <= 0.2 + 1e-9
    assert grid[int(end[1] / RES), int(end[0] / RES)] == 0
    assert math.hypot(end[0] - goal.x, end[1] - goal.y) == pytest.approx(3 * RES)  # nearest free ring
    assert end[2] == pytest.approx(1.0)
    with pytest.raises(GoalOccupied):
        nf.make_plan(grid, RES, (0.0, 0.0), Pose2D(0.3, 1.0), goal, tolerance=0.1)


def test_unknown_cells_are_passable_only_with_allow_unknown():
    grid = free_map(40, 40)
    grid[:, 20] = NO_INFORMATION
    start, goal = Pose2D(0.3, 1.0), Pose2D(1.7, 1.0)
    path = NavFn(NavfnParams(allow_unknown=True)).make_plan(grid, RES, (0.0, 0.0), start, goal)
    assert path_length(path) == pytest.approx(1.4, rel=0.02)
    with pytest.raises(NoPath):
        NavFn(NavfnParams(allow_unknown=False)).make_plan(grid, RES, (0.0, 0.0), start, goal)


def test_path_prefers_low_cost_cells():
    grid = free_map(60, 60)
    grid[25:35, 10:50] = 200  # expensive band across the straight line
    start, goal = Pose2D(0.3, 1.5), Pose2D(2.7, 1.5)
    path = NavFn().make_plan(grid, RES, (0.0, 0.0), start, goal)
    cheap = NavFn(NavfnParams(cost_factor=0.0)).make_plan(grid, RES, (0.0, 0.0), start, goal)
    assert path_length(cheap) == pytest.approx(2.4, rel=0.02)
    assert _cells_on(grid, path).mean() < _cells_on(grid, cheap).mean()


def test_astar_and_grid_path_options_also_reach_the_goal():
    grid = free_map(60, 60)
    grid[10:50, 30] = LETHAL
    start, goal = Pose2D(0.5, 1.5), Pose2D(2.5, 1.5)
    for params in (
        NavfnParams(use_dijkstra=False),
        NavfnParams(use_grid_path=True),
        NavfnParams(use_quadratic=False),
    ):
        path = NavFn(params).make_plan(grid, RES, (0.0, 0.0), start, goal)
        np.testing.assert_allclose(path[-1, :2], [goal.x, goal.y])
        assert _cells_on(grid, path).max() < LETHAL


def test_timeout_raises_planner_timeout():
    grid = free_map(300, 300)
    with pytest.raises(PlannerTimeout):
        NavFn().make_plan(grid, RES, (0.0, 0.0), Pose2D(0.1, 0.1), Pose2D(14.9, 14.9), timeout=0.0)


def test_params_reject_bad_values_and_unknown_keys():
    assert (
        load_params(NavfnParams, {"allow_unknown": False, "default_tolerance": 0.5}).default_tolerance == 0.5
    )
    with pytest.raises(ConfigError):
        load_params(NavfnParams, {"neutral_cost": 0})
    with pytest.raises(ConfigError):
        load_params(NavfnParams, {"allow_unknow": True})
