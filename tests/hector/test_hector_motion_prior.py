"""The motion prior: where the map leaves a direction free (along a corridor with no end in range),
the match follows the prediction instead of staying where it started; and ignore_unknown: scan
points in never-observed cells do not pull the match."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from common.geometry import Pose2D
from master_side.hector.grid import GridLevel
from master_side.hector.matcher import _linearise, gauss_newton, match
from master_side.hector.slam import HectorSlam, make_levels
from tests.hector.conftest import CORRIDOR, PARAMS, segment_scan

CORRIDOR_PARAMS = replace(PARAMS, map_size=1024, laser_max_dist=8.0)


def _corridor_levels():
    """The corridor's map seen from every 0.2 m of a 6 m stretch (continuous walls), and a scanner."""
    levels, helper = make_levels(CORRIDOR_PARAMS), HectorSlam(CORRIDOR_PARAMS)
    for x in np.arange(-3.0, 3.01, 0.2):
        pose = Pose2D(x, 0.0, 0.0)
        pts = helper.scan_points(segment_scan(pose, CORRIDOR, max_range=10.0))
        for lv in levels:
            lv.update(pose.as_array()[:2], pose.apply(pts))
    return levels, helper


def test_along_a_corridor_the_prior_takes_the_prediction_and_the_walls_the_rest():
    levels, helper = _corridor_levels()
    pts = helper.scan_points(segment_scan(Pose2D(), CORRIDOR, max_range=10.0))
    assert len(pts) > 100 and np.abs(pts[:, 1]).max() < 1.02  # side walls only: nothing ends in range
    # GN starts 0.25 m short of the prediction (e.g. after a coarse level) and 0.04 m off the axis
    start, anchor = np.array([-0.25, 0.04, 0.005]), np.array([0.0, 0.0, 0.0])
    w = np.array([100.0, 100.0, 0.0])
    pose, h, _ = gauss_newton(levels[0], pts, start, 30, w, anchor)
    assert abs(pose[0] - anchor[0]) < 0.03  # along the corridor: the prediction
    assert abs(pose[1]) < 0.02 and abs(pose[2]) < 0.01  # across it and in angle: the walls
    ev, vec = np.linalg.eigh(h)
    assert abs(vec[0, 0]) > 0.9 and ev[0] < 1e-3 * ev[2]  # the free direction is x, seen by the Hessian
    # match(): the prior is centred on the prediction on every level
    pose, _ = match(levels, pts, anchor + [0.0, 0.05, 0.02], prior_w=w)
    assert abs(pose[0]) < 0.03 and abs(pose[1]) < 0.02


def test_with_ignore_unknown_a_point_in_a_never_observed_cell_neither_costs_nor_pulls():
    def level(ignore: bool) -> GridLevel:
        lv = GridLevel(0.1, 40, (-2.0, -2.0), unknown=0.0, ignore_unknown=ignore)
        lv.update(np.array([0.0, 0.0]), np.array([[1.0, y] for y in np.arange(-0.5, 0.51, 0.05)]))
        return lv

    pts = np.array([[0.52, 0.0], [1.0, 0.0], [-1.5, 1.5]])  # free space, the wall, never observed
    r, j = _linearise(level(True), pts[:, 0], pts[:, 1], np.zeros(3))
    assert r[0] > 0.5 and r[1] < 0.5  # observed cells read as before
    assert r[2] == 0.0 and not j[2].any()  # the unobserved one: no residual, no gradient
    r0, _ = _linearise(level(False), pts[:, 0], pts[:, 1], np.zeros(3))
    assert r0[2] == 1.0 and np.allclose(r0[:2], r[:2])  # hector's way: it reads unknown_probability
