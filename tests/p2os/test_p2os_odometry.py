"""Odometry from the SIP's wrapping x/y counters: continuous across the wrap, rotated into the odom
frame defined by the first SIP."""

from __future__ import annotations

import math

import pytest

from common.geometry import Pose2D
from robot_side.p2os.sip import MODELS, OdometryIntegrator, Sip, position_delta, theta_to_raw


@pytest.mark.parametrize(("old", "new", "bits", "delta"), [
    (4090, 5, 12, 11), (5, 4090, 12, -11), (100, 150, 12, 50),
    (32760, 8, 15, 16), (8, 32760, 15, -16), (0, 16383, 15, 16383),
])
def test_position_delta_takes_the_short_way_round(old, new, bits, delta):
    assert position_delta(old, new, bits) == delta


def _sip(x_mm: float, y_mm: float, theta: float, model) -> Sip:
    k = model.dist_conv_factor
    return Sip(x_raw=round(x_mm / k) & 0x7FFF, y_raw=round(y_mm / k) & 0x7FFF,
               th_raw=theta_to_raw(theta, model))


@pytest.mark.parametrize("bits", [12, 15])
@pytest.mark.parametrize("subclass", ["p3at", "p3at-sh"])
def test_odometry_is_continuous_through_the_counter_wrap(bits, subclass):
    """A 40 m circle drive starting next to the 15-bit wrap: every counter wraps, odom does not jump."""
    m = MODELS[subclass]
    start = Pose2D(32700 * m.dist_conv_factor, -200.0, 2.0)  # mm, mm, rad (robot's internal frame)
    odo = OdometryIntegrator(m, bits)
    v_mm, w, dt = 1000.0, 0.25, 0.1
    pose, prev = start, None
    for _ in range(400):
        out = odo.update(_sip(pose.x, pose.y, pose.theta, m))
        truth = Pose2D(start.x / 1000, start.y / 1000, start.theta).between(
            Pose2D(pose.x / 1000, pose.y / 1000, pose.theta))
        assert out.distance(truth) < 0.01 * m.dist_conv_factor + 0.002  # quantisation only, no drift
        assert abs(math.remainder(out.theta - truth.theta, 2 * math.pi)) < 2 * m.angle_conv_factor
        if prev is not None:
            assert prev.distance(out) < v_mm * dt / 1000 * 1.05
        prev = out
        th = pose.theta + w * dt / 2
        pose = Pose2D(pose.x + v_mm * dt * math.cos(th), pose.y + v_mm * dt * math.sin(th),
                      math.remainder(pose.theta + w * dt, 2 * math.pi))


def test_first_sip_is_the_odom_origin():
    m = MODELS["p3at"]
    odo = OdometryIntegrator(m)
    assert odo.update(_sip(1234.0, 987.0, -1.0, m)).as_array() == pytest.approx([0.0, 0.0, 0.0], abs=1e-12)
    # 100 mm along the robot's heading of -1 rad is 100 mm straight ahead in odom
    p = odo.update(_sip(1234.0 + 100 * math.cos(-1.0), 987.0 + 100 * math.sin(-1.0), -1.0, m))
    assert p.x == pytest.approx(0.1, abs=0.002)
    assert p.y == pytest.approx(0.0, abs=0.002)


def test_odometry_told_the_turning_centre_adds_the_pivots_sideways_motion():
    """``odom_rotation_center_x`` (zenav): the firmware integrates every turn about the axles' middle; a P3-AT
    that pivots 0.12 m behind it moves base_link sideways as it turns. A 90 deg turn in place in 10 SIPs (the
    firmware's x, y unchanged) comes out as the turn about (c, 0): base_link at (c, -c) in the start's frame.
    Straight driving is unchanged."""
    m, c = MODELS["p3at"], -0.12
    odo, plain = OdometryIntegrator(m, rotation_center_x=c), OdometryIntegrator(m)
    for i in range(11):
        sip = _sip(500.0, -300.0, 0.3 + math.pi / 2 * i / 10, m)
        out, ref = odo.update(sip), plain.update(sip)
    assert (ref.x, ref.y) == pytest.approx((0.0, 0.0), abs=1e-9)
    assert out.as_array() == pytest.approx([c, -c, math.pi / 2], abs=2 * m.angle_conv_factor)
    later = odo.update(_sip(500.0 + 200 * math.cos(0.3 + math.pi / 2), -300.0 + 200 * math.sin(0.3 + math.pi / 2),
                            0.3 + math.pi / 2, m))
    assert out.between(later).as_array() == pytest.approx([0.2, 0.0, 0.0], abs=0.003)


def test_the_turning_centre_is_a_driver_parameter_with_a_range():
    from common.config import ConfigError
    from robot_side.p2os.node import load

    assert load({"odom_rotation_center_x": -0.12}, "p3at_real.yaml").odom_rotation_center_x == -0.12
    with pytest.raises(ConfigError, match=r"odom_rotation_center_x.*\[-2"):
        load({"odom_rotation_center_x": 5.0}, "p3at_real.yaml")
