"""AMCL on small synthetic maps: likelihood field, tracking, global localisation, resampling, params."""

from __future__ import annotations

import math

import numpy as np
import pytest

from common.config import ConfigError
from common.geometry import Pose2D
from common.messages import Header, OccupancyGrid
from master_side.localization.amcl import Amcl
from master_side.localization.likelihood_field import LikelihoodField, beam_likelihoods, select_beams
from master_side.localization.params import AmclParams, load_amcl_params
from master_side.localization.sampling import kld_limit, kld_resample
from tests.amcl.amcl_support import KINECT, LASER, RES, box_map, cast_scan, noisy_step, pose_error, route

LASER_IN_BASE = Pose2D(0.1, 0.0, 0.0)


ROUTE = route([(-3.0, 2.0, 0.0), (3.0, 2.0), (3.0, -1.0), (-1.0, -1.0), (-1.0, 2.2)])


def drive(amcl: Amcl, sensor: dict, seed: int) -> list[tuple[int, float, float]]:
    """Drive ROUTE with noisy odometry and noisy scans; (update, xy error, yaw error) per update."""
    rng = np.random.default_rng(seed)
    grid, odom, out = box_map(), Pose2D(), []
    for prev, cur in zip(ROUTE, ROUTE[1:]):
        odom = odom.compose(noisy_step(prev.between(cur), rng))
        scan = cast_scan(grid, cur.compose(LASER_IN_BASE), **sensor, noise=0.01, rng=rng)
        if amcl.update(odom, scan, LASER_IN_BASE):
            out.append((amcl.updates, *pose_error(amcl.map_to_odom().compose(odom), cur)))
    return out


def test_amcl_likelihood_field_scores_peak_at_the_true_pose():
    grid = box_map()
    field = LikelihoodField(grid, 2.0)
    truth = Pose2D(-2.0, 1.5, -0.4)
    scan = cast_scan(grid, truth.compose(LASER_IN_BASE), **LASER)
    r, a = select_beams(scan.ranges, scan.angles(), 60, scan.range_min, scan.range_max)
    offsets = np.array([(dx, dy, da) for dx in np.linspace(-0.5, 0.5, 11) for dy in np.linspace(-0.5, 0.5, 11)
                        for da in np.linspace(-0.3, 0.3, 7)])
    poses = truth.as_array() + offsets
    w = beam_likelihoods(field, poses, LASER_IN_BASE, r, a, 0.95, 0.05, 0.2, scan.range_max)
    best = offsets[int(np.argmax(w))]
    assert np.allclose(best, 0.0, atol=1e-9), best
    far = np.hypot(offsets[:, 0], offsets[:, 1]) >= 0.3
    assert w[far].max() < 0.8 * w.max()


def test_amcl_field_penalises_end_points_that_went_through_a_thin_wall_into_unknown_space():
    # a corridor: free between two 2-cell walls at y = +-1 (inner faces at +-0.9), unknown beyond
    data = np.full((60, 80), -1, np.int8)  # 4 m x 3 m at 0.05 m, origin (-2, -1.5)
    data[12:48, :] = 0
    data[10:12, :] = data[48:50, :] = 100  # walls y in [-1.0, -0.9] and [0.9, 1.0]
    grid = OccupancyGrid(Header(0.0, "map"), RES, Pose2D(-2.0, -1.5, 0.0), data)

    def d(y: float) -> float:
        return float(LikelihoodField(grid, 2.0).distance_at(np.array([[0.0, y]]))[0])

    assert d(0.875) == pytest.approx(0.025) and d(0.925) == pytest.approx(0.025)  # either side of the face
    assert d(0.5) == pytest.approx(0.375)  # free: to the face
    assert d(1.025) > d(0.975) > d(0.925)  # beyond the wall's back face it keeps growing (ROS: back to 0)
    assert d(1.225) == pytest.approx(0.325)  # depth behind the free space
    assert LikelihoodField(grid, 2.0, penalize_interior=False).distance_at(np.array([[0.0, 1.025]]))[0] \
        == pytest.approx(0.05)  # ROS: distance to the wall's back face
    # unknown far from every obstacle scores at least its distance to an obstacle (as ROS)
    open_map = np.zeros((60, 80), np.int8)
    open_map[:, :2] = 100
    open_map[:, 40:] = -1
    far = OccupancyGrid(Header(0.0, "map"), RES, Pose2D(-2.0, -1.5, 0.0), open_map)
    assert LikelihoodField(far, 5.0).distance_at(np.array([[0.1, 0.0]]))[0] >= 2.0 - 0.05


def test_amcl_likelihood_field_prob_is_the_product_and_sharper_than_the_sum_of_cubes():
    grid = box_map()
    field = LikelihoodField(grid, 2.0)
    truth = Pose2D(-2.0, 1.5, -0.4)
    scan = cast_scan(grid, truth.compose(LASER_IN_BASE), **KINECT)
    r, a = select_beams(scan.ranges, scan.angles(), 40, scan.range_min, scan.range_max)
    yaws = np.linspace(-0.1, 0.1, 21)
    poses = truth.as_array() + np.column_stack((0 * yaws, 0 * yaws, yaws))
    args = (field, poses, LASER_IN_BASE, r, a, 0.95, 0.05, 0.1, scan.range_max)
    cubes, prod = beam_likelihoods(*args), beam_likelihoods(*args, product=True)
    end = truth.compose(LASER_IN_BASE).apply(np.array([[r[0] * np.cos(a[0]), r[0] * np.sin(a[0])]]))
    pz = 0.95 * np.exp(-float(field.distance_at(end)[0]) ** 2 / (2 * 0.1**2)) + 0.05 / 10.0
    one = beam_likelihoods(field, poses[10:11], LASER_IN_BASE, r[:1], a[:1], 0.95, 0.05, 0.1, 10.0, product=True)
    assert one[0] == pytest.approx(pz, rel=1e-5)
    assert int(np.argmax(prod)) == int(np.argmax(cubes)) == 10
    # off by 0.05 rad: the product falls by orders of magnitude more than the sum of cubes
    assert prod[5] / prod[10] < 1e-3 * (cubes[5] / cubes[10])


def test_amcl_select_beams_subsamples_and_drops_unusable_ranges():
    ranges = np.array([0.2, 1.0, np.inf, 5.0, np.nan, 10.0, 2.0, 3.0])
    r, _ = select_beams(ranges, np.arange(8.0), 100, 0.45, 10.0)
    assert list(r) == [1.0, 5.0, 2.0, 3.0]  # < min, inf, nan and == max dropped
    r, a = select_beams(np.ones(320), np.arange(320.0), 30, 0.45, 10.0)
    assert len(r) == 30
    assert (a[0], a[-1]) == (0, 319)


@pytest.mark.parametrize("sensor", [KINECT, LASER], ids=["kinect57", "laser240"])
def test_amcl_tracking_converges_from_half_metre_and_0_3_rad_initial_error(sensor):
    truth0 = ROUTE[0]
    p = AmclParams(initial_pose_x=truth0.x + 0.5, initial_pose_y=truth0.y, initial_pose_a=truth0.theta + 0.3,
                   seed=3)
    hist = drive(Amcl(p, box_map()), sensor, seed=1)
    assert hist[0][1] > 0.25  # it did start wrong
    settled = [h for h in hist if h[0] >= 15]
    assert len(settled) > 30
    assert max(h[1] for h in settled) < 0.1, settled
    assert max(h[2] for h in settled) < 0.05, settled


@pytest.mark.parametrize("seed", [0, 1])
def test_amcl_global_localization_converges_in_an_asymmetric_map(seed):
    amcl = Amcl(AmclParams(seed=seed + 10), box_map())
    amcl.global_localization()
    assert len(amcl.poses) == amcl.p.max_particles
    spread = np.ptp(amcl.poses[:, :2], axis=0)
    assert spread.min() > 4.0  # uniform over the room
    hist = drive(amcl, LASER, seed=seed)
    last = hist[-15:]
    assert max(h[1] for h in last) < 0.15, hist
    assert max(h[2] for h in last) < 0.1, hist


def test_amcl_weights_stay_normalised_and_kld_adapts_the_particle_count():
    p = AmclParams(seed=5, resample_interval=1, initial_pose_x=-3.0)
    amcl = Amcl(p, box_map())
    rng = np.random.default_rng(2)
    grid, odom, truth = box_map(), Pose2D(), Pose2D(-3.0, 0.0, 0.0)
    for _ in range(24):
        step = Pose2D(0.25, 0.0, 0.0)
        truth, odom = truth.compose(step), odom.compose(noisy_step(step, rng))
        assert amcl.update(odom, cast_scan(grid, truth.compose(LASER_IN_BASE), **LASER), LASER_IN_BASE)
        assert math.isclose(amcl.weights.sum(), 1.0, rel_tol=1e-9)
        assert np.all(amcl.weights > 0)
        assert p.min_particles <= len(amcl.poses) <= p.max_particles
    assert len(amcl.poses) < p.max_particles / 2  # converged: KLD shrank the set

    rng = np.random.default_rng(0)
    wide = np.column_stack((rng.uniform(-3, 3, 5000), rng.uniform(-2, 2, 5000), rng.uniform(-3, 3, 5000)))
    tight = np.column_stack((rng.normal(0.1, 0.02, (5000, 2)), rng.normal(0, 0.02, 5000)))
    w = np.full(5000, 1 / 5000)
    n_wide = len(kld_resample(wide, w, 100, 5000, 0.01, 0.99, rng))
    n_tight = len(kld_resample(tight, w, 100, 5000, 0.01, 0.99, rng))
    assert n_tight == 100
    assert n_wide == 5000
    assert kld_limit(2, 0.01, 0.99) < kld_limit(20, 0.01, 0.99) < kld_limit(200, 0.01, 0.99)


def test_amcl_recovery_injects_random_particles_when_the_fit_drops():
    p = AmclParams(seed=4, recovery_alpha_slow=0.001, recovery_alpha_fast=0.1)
    amcl = Amcl(p, box_map())
    amcl.w_slow, amcl.w_fast = 10.0, 2.0  # the recent fit is much worse than the long-term one
    assert math.isclose(amcl.random_fraction(), 0.8)
    amcl.init_pose(Pose2D(0.0, 0.0, 0.0), (0.0001, 0.0001, 0.0001))
    amcl.w_slow, amcl.w_fast = 10.0, 2.0
    amcl._resample()
    far = np.hypot(amcl.poses[:, 0], amcl.poses[:, 1]) > 1.0
    assert far.mean() > 0.5
    assert amcl.w_slow == amcl.w_fast == 0.0


def test_amcl_params_load_ros_names_and_reject_bad_values():
    p = load_amcl_params({"min_particles": 500, "max_particles": 2000, "odom_model_type": "diff-corrected",
                          "laser_z_short": 0.1, "use_map_topic": True}, "amcl.yaml")
    assert (p.min_particles, p.max_particles, p.odom_model_type) == (500, 2000, "diff-corrected")
    bad = [{"kld_err": 0.0}, {"laser_max_beams": 1}, {"odom_model_type": "tricycle"}, {"min_particles": 10,
           "max_particles": 5}, {"laser_sigma_hit": "wide"}, {"no_such_key": 1}, {"resample_interval": 0}]
    for cfg in bad:
        with pytest.raises(ConfigError, match="amcl.yaml"):
            load_amcl_params(cfg, "amcl.yaml")
