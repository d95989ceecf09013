import math

import numpy as np
import pytest
from costmap_helpers import PaintLayer, inflation_layer, layered

from common.geometry import Pose2D
from master_side.costmap.cost_values import FREE, INSCRIBED, LETHAL, NO_INFORMATION


def expected(d: float, inscribed: float, radius: float, factor: float) -> int:
    if d == 0:
        return LETHAL
    if d <= inscribed:
        return INSCRIBED
    if d > radius:
        return FREE
    return int(math.floor(252 * math.exp(-factor * (d - inscribed))))


@pytest.mark.parametrize(("dx", "dy"),
                         [(1, 0), (2, 0), (3, 0), (2, 2), (4, 1), (5, 0), (3, 4), (6, 0), (7, 3)])
def test_inflation_values_equal_the_formula_at_sample_distances(dx, dy):
    lc = layered(4.0, 0.1, robot_radius=0.2)
    paint = lc.add_layer(PaintLayer())
    inf = inflation_layer(lc, radius=0.55, factor=4.0)
    paint.costmap.data[20, 20] = LETHAL
    lc.update_map(Pose2D())
    d = math.hypot(dx, dy) * 0.1
    want = expected(d, lc.inscribed_radius, 0.55, 4.0)
    assert lc.master.data[20 + dy, 20 + dx] == want
    assert lc.master.data[20 - dy, 20 - dx] == want
    assert inf.grid().data[20 + dy, 20 + dx] == want


def test_nearest_obstacle_wins_between_two_obstacles():
    lc = layered(4.0, 0.1)
    paint = lc.add_layer(PaintLayer())
    inflation_layer(lc, radius=1.0, factor=2.0)
    paint.costmap.data[10, 10] = LETHAL
    paint.costmap.data[10, 16] = LETHAL
    lc.update_map(Pose2D())
    # cell (12, 10) is 0.2 m from the first, 0.4 m from the second obstacle
    assert lc.master.data[10, 12] == expected(0.2, lc.inscribed_radius, 1.0, 2.0)


def test_inflation_never_creates_unknown_cells():
    rng = np.random.default_rng(3)
    lc = layered(3.0, 0.1, track_unknown=True)
    paint = lc.add_layer(PaintLayer())
    inflation_layer(lc, radius=0.6, factor=2.0)
    grid = rng.choice([FREE, 50, LETHAL, NO_INFORMATION], size=paint.costmap.data.shape,
                      p=[0.6, 0.1, 0.05, 0.25])
    paint.costmap.data[:] = grid
    lc.update_map(Pose2D())
    out = lc.master.data
    assert not np.any((out == NO_INFORMATION) & (grid != NO_INFORMATION))
    # ROS rule: unknown cells take only an inscribed or lethal inflated cost, else stay unknown
    assert set(np.unique(out[grid == NO_INFORMATION])) <= {INSCRIBED, LETHAL, NO_INFORMATION}
    assert np.any((grid == NO_INFORMATION) & (out == INSCRIBED))


def test_inflate_unknown_lets_any_inflated_cost_replace_unknown():
    lc = layered(2.0, 0.1, track_unknown=True)
    paint = lc.add_layer(PaintLayer())
    inflation_layer(lc, radius=0.8, factor=1.0, inflate_unknown=True)
    paint.costmap.data[:] = NO_INFORMATION
    paint.costmap.data[10, 10] = LETHAL
    lc.update_map(Pose2D())
    assert lc.master.data[10, 16] == expected(0.6, lc.inscribed_radius, 0.8, 1.0)
    assert lc.master.data[10, 19] == NO_INFORMATION


def test_windowed_reinflation_equals_full_inflation():
    lc = layered(4.0, 0.1)
    paint = lc.add_layer(PaintLayer())
    inf = inflation_layer(lc, radius=0.5, factor=3.0)
    paint.costmap.data[5, 5] = LETHAL
    lc.update_map(Pose2D())
    # a new obstacle changes only a small window; the result must match inflating everything
    paint.update_bounds = lambda pose, b: b.expand(2.0, 2.0, 2.05, 2.05)
    paint.costmap.data[20, 20] = LETHAL
    lc.update_map(Pose2D())
    windowed = lc.master.data.copy()
    full = inf.inflation_costs(lc.master, lc.master.full_window())
    np.testing.assert_array_equal(windowed, np.maximum(full, paint.costmap.data))


@pytest.mark.parametrize("r", [1, 4, 14, 40])
def test_truncated_distance_transform_matches_scipy_edt(r):
    from scipy.ndimage import distance_transform_edt

    from master_side.costmap.inflation_layer import squared_distance_within

    rng = np.random.default_rng(r)
    src = rng.random((90, 70)) < 0.01
    src[0, 0] = True
    want = np.rint(distance_transform_edt(~src) ** 2)
    got = squared_distance_within(src, r).astype(float)
    near = want <= r * r
    np.testing.assert_array_equal(got[near], want[near])
    assert np.all(got[~near] > r * r)
