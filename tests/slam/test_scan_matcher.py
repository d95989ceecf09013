import numpy as np

from common.geometry import Pose2D
from master_side.slam.grid import TiledGrid
from master_side.slam.gridslam import integrate, prepare_beams
from master_side.slam.params import GMappingParams
from master_side.slam.scan_matcher import ScanMatcher, make_field

P = GMappingParams(maxUrange=20.0, maxRange=25.0, search_linear=0.4, search_angular=0.15)


def _room_map(room_scan, truth: Pose2D):
    grid = TiledGrid(P.delta)
    scan = room_scan(truth)
    beams = prepare_beams(scan, P, Pose2D())
    pose = truth.as_array()
    for _ in range(3):
        win = grid.window(-6, -5, 6, 5)
        grid.store(win, integrate(win, pose, beams))
    return grid


def test_matcher_recovers_a_known_offset_in_a_synthetic_room(room_scan):
    truth = Pose2D(0.3, -0.2, 0.1)
    grid = _room_map(room_scan, truth)
    fld = make_field(grid.window(-6, -5, 6, 5), P)
    beams = prepare_beams(room_scan(truth), P, Pose2D())
    guess = truth.as_array() + np.array([0.17, -0.12, 0.06])
    pose, score = ScanMatcher(P).match(fld, guess, beams.match)
    assert abs(pose[0] - truth.x) < 0.02
    assert abs(pose[1] - truth.y) < 0.02
    assert abs(pose[2] - truth.theta) < np.radians(0.5)
    assert score > 0.6 * len(beams.match)


def test_likelihood_is_highest_at_the_true_pose(room_scan):
    truth = Pose2D(0.3, -0.2, 0.1)
    fld = make_field(_room_map(room_scan, truth).window(-6, -5, 6, 5), P)
    beams = prepare_beams(room_scan(truth), P, Pose2D())
    m = ScanMatcher(P)
    at = m.log_likelihood(fld, truth.as_array(), beams.match)
    off = m.log_likelihood(fld, truth.as_array() + [0.1, 0.0, 0.0], beams.match)
    assert at > off
