"""The Jackal of the BARN challenge in the simulator: its laser (topic, preset), base preset and the
world-aligned odometry frame; the existing defaults stay as they were."""

import math

import numpy as np
import pytest
from sim_helpers import empty_world, wall_world

from common.config import ConfigError
from common.geometry import Pose2D
from common.messages import Twist
from robot_side.sim.base import BASE_PRESETS, BaseParams, DiffDriveBase, base_preset, load_base_params
from robot_side.sim.laser import Laser, LaserParams, load_laser_params
from robot_side.sim.simulator import Simulator

NOISE_OFF = dict(srr=0.0, srt=0.0, str=0.0, stt=0.0)


def _drive(base, v, w, seconds, dt=0.01):
    for i in range(1, round(seconds / dt) + 1):
        base.set_cmd_vel(Twist.planar(v, w), i * dt)
        base.step(dt, i * dt)


def test_ust10lx_preset_has_the_challenge_values_and_any_topic():
    p = load_laser_params({"model": "hokuyo_ust10lx", "topic": "front/scan", "frame_id": "front_laser"})
    assert p.samples == 720
    assert (p.angle_min, p.angle_max) == (-2.35619, 2.35619)
    assert (p.range_min, p.range_max, p.rate) == (0.1, 30.0, 50.0)
    assert (p.topic, p.frame_id) == ("front/scan", "front_laser")
    scan = Laser(wall_world(2.0, res=0.01), p).scan(Pose2D())
    assert len(scan.ranges) == 720
    assert scan.angle_increment == pytest.approx(2 * 2.35619 / 719)
    assert scan.scan_time == pytest.approx(0.02)
    centre = np.abs(scan.angle_min + scan.angle_increment * np.arange(720)) < 0.2
    # the wall's face is at x = 2.0, the laser 0.1 m ahead of base_link by default
    assert np.allclose(scan.ranges[centre] * np.cos(scan.angle_min + scan.angle_increment
                                                     * np.flatnonzero(centre)), 1.9, atol=0.012)


def test_laser_topic_defaults_to_scan_and_bad_topics_are_rejected():
    assert LaserParams().topic == "scan"
    assert load_laser_params({"model": "sick_s300"}).topic == "scan"
    for bad in ("", "/", "front/*", "a b"):
        with pytest.raises(ConfigError, match="topic"):
            load_laser_params({"topic": bad})


def test_simulator_renders_the_ust10lx_at_50_hz():
    sim = Simulator.from_config({"world": "barn_demo", "laser": {"model": "hokuyo_ust10lx"},
                                 "depth_camera": None, "base": {"model": "jackal"}}, "test.yaml")
    stamps = [sim.time for _ in range(100) if "laser" in sim.step()]
    assert np.allclose(stamps, 0.02 * np.arange(1, 51))


def test_jackal_preset_footprint_limits_and_p3at_defaults_unchanged():
    j = load_base_params({"model": "jackal"})
    fp = np.asarray(j.footprint)
    assert fp.max(0) - fp.min(0) == pytest.approx([0.508, 0.430])
    assert fp.mean(0) == pytest.approx([0.0, 0.0])  # centred on base_link
    assert (j.max_vel_x, j.max_vel_theta, j.acc_lim_x, j.acc_lim_th) == (2.0, 4.0, 20.0, 25.0)
    assert j.odom_start_yaw_from_world
    assert j == base_preset("jackal")
    assert load_base_params({"model": "jackal", "seed": 4}).seed == 4
    assert base_preset("p3at") == BaseParams() == load_base_params({})
    assert not BaseParams().odom_start_yaw_from_world
    assert set(BASE_PRESETS) == {"p3at", "jackal", "pioneer_lx"}
    with pytest.raises(ConfigError, match="base.model"):
        load_base_params({"model": "husky"})


def test_jackal_reaches_2_m_per_s_and_4_rad_per_s_almost_at_once():
    base = DiffDriveBase(empty_world(), base_preset("jackal", **NOISE_OFF), Pose2D())
    _drive(base, 5.0, 9.0, 0.3)
    assert (base.v, base.w) == (2.0, 4.0)


@pytest.mark.parametrize("yaw", [1.57, -2.5])
def test_world_aligned_odom_starts_at_the_start_yaw_and_moves_like_the_world(yaw):
    start = Pose2D(-2.25, 3.0, yaw)
    base = DiffDriveBase(empty_world(), base_preset("jackal", **NOISE_OFF), start)
    assert base.odom == Pose2D(0.0, 0.0, yaw)
    _drive(base, 0.8, 0.3, 3.0)
    # odom = the world pose shifted to the start position (no rotation)
    assert base.odom.x == pytest.approx(base.pose.x - start.x, abs=1e-9)
    assert base.odom.y == pytest.approx(base.pose.y - start.y, abs=1e-9)
    assert math.remainder(base.odom.theta - base.pose.theta, 2 * math.pi) == pytest.approx(0.0, abs=1e-9)
    assert math.hypot(base.odom.x, base.odom.y) > 1.5


def test_default_odom_starts_at_the_origin_facing_x():
    start = Pose2D(-2.25, 3.0, 1.57)
    base = DiffDriveBase(empty_world(), BaseParams(**NOISE_OFF), start)
    assert base.odom == Pose2D()
    _drive(base, 0.5, 0.0, 2.0)
    assert base.odom.y == pytest.approx(0.0, abs=1e-9)
    # forward is odom +x
    assert base.odom.x == pytest.approx(math.hypot(base.pose.x - start.x, base.pose.y - start.y), abs=1e-9)
    assert base.odom.x > 0.5


def test_jackal_odometry_has_little_heading_drift():
    errs = []
    for seed in range(100):
        base = DiffDriveBase(empty_world(res=0.5), base_preset("jackal", seed=seed), Pose2D(0, 0, 1.57))
        _drive(base, 1.0, 0.0, 10.0, dt=0.05)
        errs.append(math.remainder(base.odom.theta - base.pose.theta, 2 * math.pi))
    p = base_preset("jackal")
    assert np.std(errs) == pytest.approx(p.str * math.sqrt(10.0), rel=0.3)
    assert np.std(errs) < 0.01  # < 0.6 deg after 10 m: an IMU-fused heading
