"""move_base's 'no robot pose' reason names the TF edge that went quiet and who published it: after a
healed link, map -> odom stopped while odom -> base_link kept coming, and the lookup error alone spoke of an
extrapolation on odom -> base_link."""

from __future__ import annotations

from common.geometry import Transform
from common.messages import Header, TransformStamped
from common.tf_buffer import TFBuffer
from master_side.move_base.robot_inputs import robot_pose


def test_a_quiet_map_to_odom_edge_is_named_with_its_age_and_publisher():
    buf = TFBuffer(cache_time=10.0)
    buf.set_transform(TransformStamped(Header(100.0, "map"), "odom", Transform()), authority="localization")
    for k in range(50):  # odometry keeps coming, 300 s later
        buf.set_transform(TransformStamped(Header(400.0 + 0.1 * k, "odom"), "base_link", Transform()), authority="sim")
    pose, _, _, why = robot_pose(buf, "map", "odom", "base_link", 0.5, 405.0)
    assert pose is None
    assert why.startswith("no robot pose: "), why
    assert "oldest edge map -> odom (305.00 s, from localization)" in why, why
