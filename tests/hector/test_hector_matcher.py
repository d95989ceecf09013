import math

import numpy as np

from common.geometry import Pose2D
from master_side.hector.grid import GridLevel
from master_side.hector.matcher import gauss_newton, match
from tests.hector.conftest import room_levels


def test_bilinear_gradient_matches_numerical_derivative():
    rng = np.random.default_rng(1)
    lv = GridLevel(0.1, 32, (-1.6, -1.6))
    lv.prob[:] = rng.uniform(0.0, 1.0, lv.prob.shape)
    x, y = rng.uniform(-1.2, 1.2, 50), rng.uniform(-1.2, 1.2, 50)
    v, dx, dy = lv.interp(x, y)
    h = 1e-5
    nx = (lv.interp(x + h, y)[0] - lv.interp(x - h, y)[0]) / (2 * h)
    ny = (lv.interp(x, y + h)[0] - lv.interp(x, y - h)[0]) / (2 * h)
    assert np.allclose(dx, nx, atol=1e-3) and np.allclose(dy, ny, atol=1e-3)
    assert np.all((v >= 0) & (v <= 1))


def test_interpolation_returns_cell_values_at_cell_centres_and_zero_outside():
    lv = GridLevel(0.1, 8, (0.0, 0.0))
    lv.prob[3, 5] = 0.9  # row = y
    v, _, _ = lv.interp(np.array([0.55, 5.0]), np.array([0.35, 5.0]))
    assert math.isclose(v[0], 0.9, abs_tol=1e-6) and v[1] == 0.0


def test_map_update_marks_endpoints_occupied_and_the_beam_free():
    lv = GridLevel(0.1, 40, (-2.0, -2.0))
    lv.update(np.array([0.0, 0.0]), np.array([[1.52, 0.03]]))
    row = lv.logodds[20]
    assert row[35] > 0  # the endpoint's cell (x 1.5..1.6)
    assert np.all(row[21:34] < 0) and row[36] == 0  # free up to the wall, unknown behind it


def test_gauss_newton_recovers_a_known_offset_on_the_finest_level(room_scan):
    truth = Pose2D(0.3, -0.2, 0.1)
    levels, helper = room_levels(truth)
    pts = helper.scan_points(room_scan(truth))
    pose, h, _ = gauss_newton(levels[0], pts, truth.as_array() + [0.04, -0.03, 0.02], 10)
    assert np.hypot(*(pose[:2] - truth.as_array()[:2])) < 0.01 and abs(pose[2] - truth.theta) < 0.005
    assert np.all(np.linalg.eigvalsh(h) > 0)


def test_multi_resolution_converges_from_further_than_the_finest_level_alone(room_scan):
    truth = Pose2D(0.3, -0.2, 0.1)
    levels, helper = room_levels(truth)
    pts = helper.scan_points(room_scan(truth))
    start = truth.as_array() + [0.25, -0.2, 0.12]
    fine_only, _, _ = gauss_newton(levels[0], pts, start, 20)
    pose, cov = match(levels, pts, start, 5, 10)
    err = np.hypot(*(pose[:2] - truth.as_array()[:2]))
    assert err < 0.01 and abs(pose[2] - truth.theta) < 0.005
    assert np.hypot(*(fine_only[:2] - truth.as_array()[:2])) > 5 * err
    # a proper covariance: symmetric, positive definite, small for a well-matched room
    assert np.allclose(cov, cov.T) and np.all(np.linalg.eigvalsh(cov) > 0) and cov[0, 0] < 0.01
