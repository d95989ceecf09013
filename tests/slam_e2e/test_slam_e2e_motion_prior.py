"""The matcher's motion prior on the degenerate case behind the online room map: a narrow (Kinect-like)
scan of a plain wall, after moving along it, constrains only the distance to the wall."""

from __future__ import annotations

import math

import numpy as np

from common.geometry import Pose2D
from common.messages import Header, LaserScan
from master_side.slam.grid import TiledGrid
from master_side.slam.gridslam import integrate, prepare_beams
from master_side.slam.params import GMappingParams
from master_side.slam.scan_matcher import MotionPrior, ScanMatcher, make_field

P = GMappingParams(maxUrange=6.0, maxRange=10.0)
WALL_Y = 2.0


def _wall_scan(pose: Pose2D, fov: float = math.radians(57.0), n: int = 320) -> LaserScan:
    """Ranges to the wall y = WALL_Y from ``pose`` (looking towards it)."""
    ang = -fov / 2 + fov / (n - 1) * np.arange(n)
    s = np.sin(pose.theta + ang)
    r = np.where(s > 1e-6, (WALL_Y - pose.y) / np.maximum(s, 1e-6), np.inf)
    return LaserScan(Header(0.0, "laser"), -fov / 2, fov / 2, fov / (n - 1), 0.0, 0.0, 0.45, 10.0,
                     r.astype(np.float32))


def _match(prior: bool) -> np.ndarray:
    first, second = Pose2D(0.0, 0.0, math.pi / 2), Pose2D(0.3, 0.0, math.pi / 2)  # moved along the wall
    grid = TiledGrid(P.delta)
    beams = prepare_beams(_wall_scan(first), P, Pose2D())
    win = grid.window(-4, -2, 4, 4)
    for _ in range(3):
        grid.store(win, integrate(win, first.as_array(), beams))
    fld = make_field(grid.window(-4, -2, 4, 4), P)
    pts = prepare_beams(_wall_scan(second), P, Pose2D()).match
    pred = second.as_array()  # exact odometry
    w = P.prior_weight  # exact odometry: only the floors of the prior variance remain
    mp = MotionPrior(pred, w / P.prior_sigma_xy**2, w / P.prior_sigma_theta**2) if prior else None
    pose, _ = ScanMatcher(P).match(fld, pred, pts, (0.4, 0.15), prior=mp)
    return pose - pred


def test_slam_e2e_without_a_prior_a_plain_wall_pulls_the_scan_onto_the_mapped_part():
    err = _match(prior=False)
    assert abs(err[0]) > 0.1  # the degenerate direction slides towards the already-mapped wall


def test_slam_e2e_with_the_motion_prior_the_pose_along_a_plain_wall_follows_odometry():
    err = _match(prior=True)
    assert abs(err[0]) < 2 * P.delta
    assert abs(err[1]) < P.delta
    # rotation is pulled too (endpoints swing along the wall) but the prior's rotation floor is
    # loose on purpose (the simulated odometry's heading drifts by degrees): only a sanity bound
    assert abs(err[2]) < math.radians(3.0)
