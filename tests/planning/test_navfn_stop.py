"""navfn's local stop bar (``propagate(rise=...)``) ends the wavefront earlier than the global one
without changing the goal's potential or the path read from it (random small maps)."""

from __future__ import annotations

import numpy as np
import pytest
from planning_helpers import inflate
from reference_impl import propagate_reference

from master_side.planning.gradient_path import descend
from master_side.planning.grid import LETHAL
from master_side.planning.navfn import OBSTACLE_COST, NavfnParams
from master_side.planning.potential import INV_SQRT2, pad_costs, propagate


def _maze(rng, n: int) -> np.ndarray:
    g = np.zeros((n, n), np.uint8)
    for _ in range(int(rng.integers(3, 12))):
        r0, c0 = rng.integers(0, n, 2)
        h, w = rng.integers(1, n // 3, 2)
        g[r0:r0 + h, c0:c0 + w] = LETHAL
    return inflate(g, 0.05, inscribed=0.1, radius=0.3)


@pytest.mark.parametrize("seed", range(12))
def test_local_stop_bar_gives_the_same_goal_potential_and_path(seed):
    rng = np.random.default_rng(300 + seed)
    grid = _maze(rng, int(rng.integers(30, 90)))
    p = NavfnParams()
    free = np.argwhere(grid < 253)
    (sr, sc), (gr, gc) = free[rng.integers(len(free), size=2)]
    h, w = grid.shape
    cost = p.cell_costs(grid)
    wp = w + 2
    src, stop = (sr + 1) * wp + sc + 1, (gr + 1) * wp + gc + 1
    kw = dict(margin=3.0 * OBSTACLE_COST)
    local, cyc = propagate(pad_costs(cost), wp, src, stop, rise=INV_SQRT2 * p.neutral_cost, **kw)
    ref, ref_cyc = propagate_reference(pad_costs(cost), wp, src, stop, **kw)
    assert cyc <= ref_cyc
    assert local[stop] == ref[stop]
    reached = np.isfinite(local)
    assert np.isfinite(ref[reached]).all() and (local[reached] >= ref[reached]).all()  # the same run, cut short
    if np.isfinite(ref[stop]):
        paths = [descend(pot.reshape(h + 2, w + 2), (gr + 1, gc + 1), done_below=p.neutral_cost * 0.999)
                 for pot in (local, ref)]
        np.testing.assert_array_equal(paths[0], paths[1])


def test_local_stop_bar_saves_cycles_in_open_space():
    """In the open the diagonal fronts lag the axis ones (one step per turn either way): a goal straight
    ahead is certified long before the global bar would pass it."""
    grid = np.zeros((80, 80), np.uint8)
    p = NavfnParams()
    wp = 82
    src, stop = 41 * wp + 11, 41 * wp + 71
    cost = pad_costs(p.cell_costs(grid))
    _, local = propagate(cost, wp, src, stop, margin=3.0 * OBSTACLE_COST, rise=INV_SQRT2 * p.neutral_cost)
    _, glob = propagate(cost, wp, src, stop, margin=3.0 * OBSTACLE_COST)
    assert local < 0.9 * glob
