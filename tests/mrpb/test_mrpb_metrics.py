"""MRPB's metrics (deploy/mrpb/metrics.py) on runs whose answers are known by construction."""

from __future__ import annotations

import numpy as np
import pytest

from common.geometry import Pose2D
from common.messages import OccupancyGrid
from deploy.mrpb.metrics import DistanceField, compute, danger_share


def _wall_grid() -> OccupancyGrid:
    """10 m x 10 m at 0.1 m, origin (-5, -5): one occupied column of cells at x in [2.0, 2.1)."""
    data = np.zeros((100, 100), np.int8)
    data[:, 70] = 100
    return OccupancyGrid(resolution=0.1, origin=Pose2D(-5.0, -5.0, 0.0), data=data)


def test_distance_field_is_the_distance_to_the_nearest_occupied_cell_centre():
    f = DistanceField.of(_wall_grid())
    centre_x = -5.0 + 70.5 * 0.1  # the wall cells' centres: x = 2.05
    for x in (-1.0, 0.55, 1.0, 1.75):
        assert f.at(np.array([x]), np.array([0.3]))[0] == pytest.approx(centre_x - x, abs=1e-6)


def test_a_straight_run_at_constant_acceleration_then_cruise():
    # 0..5 s accelerating at 0.2 m/s^2 then 5 s at 1 m/s along y = 0, 20 Hz, away from the wall at x = 2.05
    t = np.arange(0, 10.0001, 0.05)
    v = np.minimum(0.2 * t, 1.0)
    x = np.where(t <= 5.0, 0.1 * t**2, 2.5 + (t - 5.0)) - 9.0  # from x = -9 to x = -1.5
    trace = np.stack([t, x, np.zeros_like(t), np.zeros_like(t), v, np.zeros_like(t)], axis=1)
    m = compute(trace, DistanceField.of(_wall_grid()), safe_distance=4.0)
    assert m.time_s == pytest.approx(10.0)
    assert m.path_m == pytest.approx(7.5, abs=1e-6)
    assert m.d_min_m == pytest.approx(2.05 + 1.5, abs=1e-6)
    assert m.accel_mean == pytest.approx(0.1, abs=0.005)  # 0.2 m/s^2 for half the time, 0 after
    assert m.jerk_mean == pytest.approx(0.2 / 0.05 / len(t), rel=0.2)  # one step of the acceleration
    assert m.ang_accel_mean == 0.0
    assert m.path_smoothness == pytest.approx(0.0, abs=1e-3)
    # within 4 m of the wall from x = -1.95: the last 0.45 m, driven at 1 m/s
    assert m.danger_pct == pytest.approx(0.45 / 10.0 * 100, abs=1.0)


def test_danger_share_counts_each_stretch_from_its_first_sample_to_its_last_as_mrpb_does():
    t = np.arange(11, dtype=float)
    d = np.array([1, 1, 0.2, 0.2, 0.2, 1, 0.2, 1, 0.2, 0.2, 1], float)
    # stretches: samples 2..4 (2 s), 6 alone (0 s), 8..9 (1 s) over a 10 s run
    assert danger_share(t, d, 0.5) == pytest.approx(30.0)
    assert danger_share(t, np.full(11, 0.1), 0.5) == pytest.approx(100.0)
    assert danger_share(t, np.ones(11), 0.5) == 0.0


def test_a_run_too_short_to_measure_gives_nan_not_an_error():
    m = compute(np.zeros((1, 6)), DistanceField.of(_wall_grid()), 0.5)
    assert np.isnan(m.time_s) and np.isnan(m.d_min_m)
