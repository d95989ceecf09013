"""refine_pose: the local search of one scan's likelihood (refine.py) and AMCL with it (zenav)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from common.config import ConfigError
from common.geometry import Pose2D
from common.messages import Header, OccupancyGrid
from master_side.localization.amcl import Amcl
from master_side.localization.likelihood_field import surface_distance
from master_side.localization.params import AmclParams, load_amcl_params
from master_side.localization.refine import REACH_M, REACH_RAD, PoseRefiner
from tests.amcl.amcl_support import (
    LASER,
    RES,
    box_map,
    cast,
    cast_scan,
    noisy_step,
    pose_error,
    route,
    solid_world,
)

LASER_IN_BASE = Pose2D(0.1, 0.0, 0.0)
SIGMA = 0.05


def refiner(grid: OccupancyGrid, range_max: float = LASER["range_max"]) -> PoseRefiner:
    return PoseRefiner(grid, 2.0, True, 0.95, 0.05, SIGMA, range_max)


def beams(grid: OccupancyGrid, truth: Pose2D, surface: str = "cell_centre") -> tuple[np.ndarray, np.ndarray]:
    """The usable beams (ranges, angles) of ``cast``."""
    r = cast(grid, solid_world(grid, surface), truth.compose(LASER_IN_BASE))
    angles = np.linspace(-LASER["fov"] / 2, LASER["fov"] / 2, LASER["beams"])
    return r[np.isfinite(r)], angles[np.isfinite(r)]


@pytest.mark.parametrize("offset", [(0.05, -0.04, 0.03), (-0.07, 0.02, -0.05), (0.0, 0.0, 0.0)])
def test_refine_finds_the_scans_pose_from_a_few_centimetres_off(offset):
    grid = box_map()
    truth = Pose2D(-2.0, 1.5, -0.4)
    r, a = beams(grid, truth)
    start = Pose2D(*(np.asarray(truth.as_array()) + offset))
    found = refiner(grid).refine(start, LASER_IN_BASE, r, a)
    xy, yaw = pose_error(found, truth)
    assert xy < 0.005 and yaw < 0.003, (found, truth)  # a fraction of a cell (RES = 0.05 m)


def test_refine_stays_within_its_reach_and_keeps_the_start_without_beams():
    grid = box_map()
    truth = Pose2D(-2.0, 1.5, -0.4)
    r, a = beams(grid, truth)
    start = Pose2D(truth.x + 0.5, truth.y, truth.theta)  # beyond reach: it moves towards the truth, no further
    found = refiner(grid).refine(start, LASER_IN_BASE, r, a)
    assert abs(found.x - start.x) <= REACH_M + 1e-9 and abs(found.theta - start.theta) <= REACH_RAD + 1e-9
    assert found.x < start.x - 0.05
    empty = np.array([])
    assert refiner(grid).refine(start, LASER_IN_BASE, empty, empty) == start


def test_refine_along_a_featureless_corridor_corrects_across_and_keeps_the_odometrys_guess_along():
    # walls at y = +-1 (inner faces at +-0.9), 20 m long: a laser in the middle never sees their ends
    data = np.zeros((60, 400), np.int8)
    data[10:12, :] = data[48:50, :] = 100
    grid = OccupancyGrid(Header(0.0, "map"), RES, Pose2D(-10.0, -1.5, 0.0), data)
    truth = Pose2D(0.0, 0.2, 0.0)
    r, a = beams(grid, truth)
    assert np.all(np.abs(r * np.cos(a)) < 8.0)  # no beam reaches an end of the corridor
    start = Pose2D(0.06, 0.16, 0.02)
    found = refiner(grid).refine(start, LASER_IN_BASE, r, a)
    assert found.x == pytest.approx(start.x, abs=1e-9)  # nothing says where along: the start stands
    assert abs(found.y - truth.y) < 0.01 and abs(found.theta) < 0.004


def test_scores_are_the_beam_model_at_cell_centres_and_the_saturated_value_off_the_map():
    grid = box_map()
    ref = refiner(grid)
    dist = surface_distance(grid, 2.0, True, "centre")
    origin = np.array([grid.origin.x, grid.origin.y])
    for row, col in ((40, 30), (1, 50), (0, 50)):  # free; the wall's first occupied layer; one deeper
        centre = origin + (np.array([col, row]) + 0.5) * RES
        pose = np.array([[centre[0] - 0.1, centre[1], 0.0]])  # the beam ends 0.1 m ahead, on the centre
        one = ref.log_likelihoods(pose, Pose2D(), np.array([0.1]), np.array([0.0]))
        d = dist[row, col]
        assert one[0] == pytest.approx(math.log(0.95 * math.exp(-d * d / (2 * SIGMA**2)) + 0.05 / 8.0))
    assert dist[1, 50] == 0.0 and dist[0, 50] == pytest.approx(RES)  # the bottom wall is rows 0-1
    assert dist[2, 50] == pytest.approx(RES) and dist[4, 50] == pytest.approx(3 * RES)
    far = ref.log_likelihoods(np.array([[100.0, -50.0, 0.3]]), Pose2D(), np.array([1.0, 2.0]), np.zeros(2))
    assert far[0] == pytest.approx(2 * math.log(0.95 * math.exp(-4.0 / (2 * SIGMA**2)) + 0.05 / 8.0))


def test_on_a_map_drawn_from_geometry_the_refined_pose_is_half_a_cell_off():
    """The limit of refine_pose: surfaces on the cells' faces (the simulator's worlds), not at their centres."""
    grid = box_map()
    truth = Pose2D(-2.0, 1.5, -0.4)
    r, a = beams(grid, truth, "cell_face")
    off = refiner(grid).refine(truth, LASER_IN_BASE, r, a)
    assert 0.015 < pose_error(off, truth)[0] < 0.05  # RES / 2 = 0.025 along each wall's normal


ROUTE_LEGS = [(-3.0, 2.0), (3.0, 2.0), (3.0, -1.0), (-1.0, -1.0), (-1.0, 2.2)]


def drive_biased(refine: bool, seed: int) -> list[float]:
    """Drive the box room's legs with odometry that drifts in heading (0.06 rad per metre, as intel's
    does about 3.5 deg/m) and scans with 1 cm noise; AMCL's error at every scan once it has settled."""
    grid = box_map()
    solid = solid_world(grid)
    truth_route = route(ROUTE_LEGS)
    p = AmclParams(seed=seed, initial_pose_x=-3.0, initial_pose_y=2.0, initial_cov_xx=0.01, initial_cov_yy=0.01,
                   initial_cov_aa=0.001, laser_model_type="likelihood_field_prob", laser_sigma_hit=SIGMA,
                   refine_pose=refine)
    amcl, rng, odom, errors = Amcl(p, grid), np.random.default_rng(seed), Pose2D(), []
    template = cast_scan(grid, truth_route[0], **LASER)
    for k, (prev, cur) in enumerate(zip(truth_route, truth_route[1:])):
        step = prev.between(cur)
        drift = Pose2D(0.0, 0.0, -0.06 * math.hypot(step.x, step.y))
        odom = odom.compose(noisy_step(step, rng)).compose(drift)
        ranges = cast(grid, solid, cur.compose(LASER_IN_BASE), step=0.0025) + rng.normal(0.0, 0.01, LASER["beams"])
        amcl.update(odom, replace(template, ranges=ranges.astype(np.float32)), LASER_IN_BASE)
        if k >= 40:
            errors.append(pose_error(amcl.map_to_odom().compose(odom), cur)[0])
    return errors


def test_amcl_with_refine_pose_follows_drifting_odometry_closer_than_the_cloud_alone():
    plain, refined = drive_biased(False, seed=2), drive_biased(True, seed=2)
    print(f"mean error {np.mean(plain):.4f} -> {np.mean(refined):.4f} m, max {max(plain):.4f} -> {max(refined):.4f}")
    # measured: mean 0.028 -> 0.002 m, max 0.057 -> 0.006 m
    assert np.mean(refined) < 0.25 * np.mean(plain)
    assert max(refined) < 0.015


def test_a_filter_update_moves_the_particles_with_the_correction():
    grid = box_map()
    truth = Pose2D(-2.0, 1.5, -0.4)
    scan = replace(cast_scan(grid, truth, **LASER),
                   ranges=cast(grid, solid_world(grid), truth.compose(LASER_IN_BASE)).astype(np.float32))
    means = {}
    for refine in (False, True):
        p = AmclParams(seed=1, initial_pose_x=truth.x + 0.05, initial_pose_y=truth.y, initial_pose_a=truth.theta,
                       initial_cov_xx=1e-6, initial_cov_yy=1e-6, initial_cov_aa=1e-8, refine_pose=refine)
        amcl = Amcl(p, grid)
        assert amcl.update(Pose2D(), scan, LASER_IN_BASE)
        means[refine] = amcl.poses.mean(axis=0)
        if refine:
            assert pose_error(amcl.mean, truth)[0] < 0.005
    # a 1 mm cloud 5 cm off: reweighing alone cannot move it, the correction does
    assert abs(means[False][0] - (truth.x + 0.05)) < 0.005
    assert abs(means[True][0] - truth.x) < 0.005


def test_refine_pose_params_load_and_are_off_by_default():
    assert AmclParams().refine_pose is False
    p = load_amcl_params({"refine_pose": True, "refine_max_beams": 90}, "amcl.yaml")
    assert (p.refine_pose, p.refine_max_beams) == (True, 90)
    for bad in ({"refine_max_beams": 1}, {"refine_pose": "yes please"}):
        with pytest.raises(ConfigError, match=f"amcl.yaml.*{next(iter(bad))}"):
            load_amcl_params(bad, "amcl.yaml")
