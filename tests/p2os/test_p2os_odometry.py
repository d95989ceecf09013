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
