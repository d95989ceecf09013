"""common.robot_logs: the CARMEN parsing both log readers (`zenav slam run`, `zenav play`) build on."""

from __future__ import annotations

import numpy as np
import pytest

from common.robot_logs import LogError, ScanRecord, carmen_laser, carmen_odom, read_carmen_lines
from deploy.logs.readers import open_log
from master_side.slam.logs import read_carmen

# ROBOTLASER1 type start fov res max_range accuracy remission_mode n ranges... m remissions... laser_x laser_y
# laser_theta robot_x robot_y robot_theta tv rv forward_safety side_safety turn_axis ipc_timestamp host logger_time
ROBOTLASER = ("ROBOTLASER1 0 -1.5 3.0 0.5 30.0 0.1 0 7 1 2 3 4 5 6 7 2 0.5 0.5 1.0 2.0 0.3 0.9 1.1 0.4 "
              "0.2 0.3 0.5 0.7 0.1 {t} host {t}\n")
ODOM = "ODOM 0.5 0.25 0.1 0.4 0.05 0.0 {t} host {t}\n"


def test_robotlaser1_line_keeps_its_own_beam_geometry_and_the_robot_pose():
    rec = carmen_laser(ROBOTLASER.format(t=20.5).split())
    assert isinstance(rec, ScanRecord) and rec.stamp == 20.5 == rec.scan.header.stamp
    assert (rec.scan.angle_min, rec.scan.angle_increment, rec.scan.angle_max) == (-1.5, 0.5, 1.5)
    assert rec.scan.range_max == 30.0 and rec.scan.header.frame_id == "laser"
    np.testing.assert_array_equal(rec.scan.ranges, np.arange(1, 8, dtype=np.float32))
    assert (rec.odom.x, rec.odom.y, rec.odom.theta) == (0.9, 1.1, 0.4)  # the robot pose, not the laser's


def test_odom_line_is_planar_odometry_and_rejects_non_finite_values():
    odom = carmen_odom(ODOM.format(t=3.0).split())
    assert (odom.header.stamp, odom.header.frame_id, odom.child_frame_id) == (3.0, "odom", "base_link")
    assert odom.pose2d.as_array() == pytest.approx((0.5, 0.25, 0.1))
    assert (odom.twist.linear.x, odom.twist.angular.z) == (0.4, 0.05)
    with pytest.raises(ValueError, match="not a finite number"):
        carmen_odom(ODOM.format(t="nan").split())


def test_read_carmen_lines_parses_only_the_asked_line_types_and_names_a_bad_line(tmp_path):
    log = tmp_path / "r.clf"
    log.write_text("# comment\n\n" + ODOM.format(t=1.0) + "PARAM a 1\n" + ODOM.format(t=2.0) + "ODOM 1 2\n")
    stamps = read_carmen_lines(log, {"ODOM": lambda t: float(t[7])})
    assert [next(stamps), next(stamps)] == [1.0, 2.0]
    with pytest.raises(LogError, match=r"r\.clf:6: malformed ODOM line"):
        next(stamps)
    assert list(read_carmen_lines(log, {"FLASER": carmen_laser})) == []


def test_slam_and_play_readers_see_the_same_robotlaser1_scans_and_poses(tmp_path):
    log = tmp_path / "robot.log"
    log.write_text(ROBOTLASER.format(t=20.5) + ODOM.format(t=20.6) + ROBOTLASER.format(t=20.7))
    slam = list(read_carmen(log))
    recs, info = open_log(log)
    played = list(recs)
    assert [r.topic for r in played] == ["tf_static", "tf", "scan", "odom", "tf", "scan"]
    assert (info.start, info.end, info.counts["scan"], info.counts["odom"]) == (20.5, 20.7, 2, 1)
    scans = [r.msg for r in played if r.topic == "scan"]
    poses = [r.msg.transforms[0].transform.to_pose2d() for r in played if r.topic == "tf"]
    assert [s.stamp for s in slam] == [s.header.stamp for s in scans] == [20.5, 20.7]
    for s, scan, pose in zip(slam, scans, poses):
        assert (scan.header, scan.angle_min, scan.angle_increment) == (s.scan.header, -1.5, 0.5)
        np.testing.assert_array_equal(scan.ranges, s.scan.ranges)
        assert pose.as_array() == pytest.approx(s.odom.as_array(), abs=1e-12)
