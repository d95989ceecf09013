"""DWA's goal-front cell, computed from the last plan segment only, is MapGrid.local_goal_cell's."""

from __future__ import annotations

import numpy as np
import pytest

from master_side.planning.grid import NO_INFORMATION
from master_side.planning.local.goal_cell import pushed_goal_cell
from master_side.planning.local.grid_distance import MapGrid


@pytest.mark.parametrize("seed", range(4))
def test_pushed_goal_cell_matches_the_whole_plan_walk(seed):
    rng = np.random.default_rng(400 + seed)
    for trial in range(300):
        h, w = rng.integers(5, 40, 2)
        grid = np.zeros((h, w), np.uint8)
        if trial % 2:  # unknown cells end the plan's run like leaving the map does
            grid[rng.integers(0, h, 10), rng.integers(0, w, 10)] = NO_INFORMATION
        res = float(rng.choice([0.025, 0.05, 0.1]))
        origin = rng.uniform(-1, 1, 2)
        plan = origin + rng.uniform(-0.3, 1.3, (int(rng.integers(1, 8)), 2)) * np.array([w, h]) * res
        end = plan[-1] + rng.uniform(-0.5, 0.5, 2)
        pushed = plan.copy()
        pushed[-1] = end
        for _ in range(2):  # the second call reads the remembered prefix
            got = pushed_goal_cell(grid, res, origin, plan, end)
            assert got == MapGrid(grid, res, origin).local_goal_cell(pushed)
