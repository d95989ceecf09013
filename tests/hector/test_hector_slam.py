from dataclasses import replace

import numpy as np

from common.geometry import Pose2D
from master_side.hector.slam import HectorSlam
from tests.hector.conftest import PARAMS


def _drive(slam: HectorSlam, room_scan, poses) -> list[Pose2D]:
    return [slam.process(0.2 * k, room_scan(p)) for k, p in enumerate(poses)]


def test_a_drive_through_a_room_is_tracked_to_a_cell_without_odometry(room_scan):
    truth = [Pose2D(-1.5 + 0.08 * k, -0.5 + 0.02 * k, 0.03 * k) for k in range(30)]
    est = _drive(HectorSlam(replace(PARAMS, map_update_distance_thresh=0.2)), room_scan, truth)
    first = truth[0]
    for t, e in zip(truth, est):
        rel = first.between(t)
        assert np.hypot(e.x - rel.x, e.y - rel.y) < 0.05 and abs(e.theta - rel.theta) < 0.01  # a cell


def test_one_scan_out_of_order_is_not_extrapolated_with_a_median_velocity(room_scan):
    poses = [Pose2D(-1.5 + 0.1 * k, 0.0, 0.0) for k in range(8)]
    poses.insert(6, Pose2D(-1.5 + 0.1 * 4.5, 0.0, 0.0))  # a scan from a little back, as in the logs
    slam = HectorSlam(replace(PARAMS, velocity_window=5))
    _drive(slam, room_scan, poses)
    assert slam.predict(0.0).x - slam.pose.x > 0.05  # still forward after the odd step
    last_step = HectorSlam(replace(PARAMS, velocity_window=1))
    _drive(last_step, room_scan, poses[:7])
    assert last_step.predict(0.0).x < last_step.pose.x  # the last step alone points backwards
