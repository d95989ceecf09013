import math

import numpy as np
import pytest
from sim_helpers import wall_world

from common.config import ConfigError
from common.geometry import Pose2D
from robot_side.sim.laser import LASER_PRESETS, Laser, LaserParams, load_laser_params
from robot_side.sim.world import World

RES = 0.02


def _laser(world, **kw):
    base = dict(x=0.0, y=0.0, z=0.35, yaw=0.0, noise_std=0.0, samples=720,
                angle_min=-math.radians(135), angle_max=math.radians(135))
    return Laser(world, LaserParams(**{**base, **kw}))


def test_wall_ranges_follow_d_over_cos_and_no_return_is_inf():
    d = 2.013
    laser = _laser(wall_world(d, half_width=4.0))
    scan = laser.scan(Pose2D())
    a = scan.angles()
    r = scan.ranges.astype(float)
    on_wall = np.abs(a) < math.atan(4.0 / (d + 0.2)) - 0.02
    assert on_wall.sum() > 300
    np.testing.assert_array_less(np.abs(r[on_wall] * np.cos(a[on_wall]) - d), RES)
    behind = np.abs(a) > math.radians(95)
    assert np.all(np.isposinf(r[behind]))
    assert scan.ranges.dtype == np.float32
    assert len(scan.ranges) == 720


def test_scan_from_a_rotated_and_translated_robot_matches_geometry():
    d = 3.0
    laser = _laser(wall_world(d), x=0.1, yaw=0.3)
    robot = Pose2D(0.5, 0.4, -0.3)  # sensor at (0.6, 0.4) heading 0 in the world
    scan = laser.scan(robot)
    a, r = scan.angles(), scan.ranges.astype(float)
    front = np.abs(a) < 0.8
    np.testing.assert_array_less(np.abs(r[front] * np.cos(a[front]) - (d - 0.6)), RES)


def test_obstacle_below_mount_height_is_not_seen_taller_one_is():
    low = {"center": [1.0, 0.0], "size": [0.2, 0.2], "height": 0.2}
    tall = {"center": [1.0, 1.0], "size": [0.2, 0.2], "height": 0.5}
    laser = _laser(wall_world(3.0, extra_boxes=[low, tall]), z=0.35)
    scan = laser.scan(Pose2D())
    a, r = scan.angles(), scan.ranges
    straight = np.argmin(np.abs(a))
    assert abs(r[straight] - 3.0) < RES  # sees the wall through the low box
    to_tall = np.argmin(np.abs(a - math.atan2(1.0, 0.9)))
    assert r[to_tall] < 1.5


def test_range_limits_follow_rep117():
    far = _laser(wall_world(3.0), range_max=2.5).scan(Pose2D())
    assert np.all(np.isposinf(far.ranges))
    near = _laser(wall_world(0.3), range_min=0.5).scan(Pose2D())
    a = near.angles()
    assert np.all(np.isneginf(near.ranges[np.abs(a) < 0.5]))


def test_noise_has_the_configured_std():
    world = wall_world(2.0)
    exact = _laser(world).ranges_exact(Pose2D())
    noisy = _laser(world, noise_std=0.03, seed=7)
    finite = np.isfinite(exact)
    err = np.concatenate([noisy.scan(Pose2D()).ranges[finite] - exact[finite] for _ in range(20)])
    assert abs(err.std() - 0.03) < 0.003
    assert abs(err.mean()) < 0.003


def test_matches_a_fine_ray_march_in_a_random_world():
    rng = np.random.default_rng(5)
    boxes = [{"center": list(rng.uniform(-3, 3, 2)), "size": list(rng.uniform(0.05, 0.8, 2)),
              "yaw": float(rng.uniform(0, 3)), "height": 1.0} for _ in range(25)]
    cyl = [{"center": list(rng.uniform(-3, 3, 2)), "radius": float(rng.uniform(0.05, 0.3)), "height": 1.0}
           for _ in range(5)]
    world = World.from_shapes({"bounds": [-4, -4, 4, 4], "resolution": RES, "boxes": boxes, "cylinders": cyl})
    laser = _laser(world, angle_min=-math.pi, angle_max=math.pi * 0.999, samples=360, range_max=10.0)
    for _ in range(5):
        pose = Pose2D(*rng.uniform(-3, 3, 2), rng.uniform(-3, 3))
        if world.height_at(np.array([pose.x]), np.array([pose.y]))[0] > 0:
            continue
        got = laser.ranges_exact(pose)
        step = 0.002
        t = np.arange(step, 10.0, step)
        ang = laser.angles + pose.theta
        xs = pose.x + np.cos(ang)[:, None] * t
        ys = pose.y + np.sin(ang)[:, None] * t
        solid = world.height_at(xs, ys) > 0.35
        ref = np.where(solid.any(1), t[np.argmax(solid, 1)], np.inf)
        with np.errstate(invalid="ignore"):
            agree = (np.isinf(ref) & np.isinf(got)) | (np.abs(got - ref) <= step + 1e-9)
        assert agree.mean() > 0.99  # a march this fine can still miss a clipped cell corner


def test_presets_and_loader():
    s300 = Laser.preset("sick_s300")
    assert s300.samples == 541
    assert math.isclose(s300.angle_max - s300.angle_min, math.radians(270))
    assert (s300.range_min, s300.range_max) == (0.05, 30.0)
    urg = load_laser_params({"model": "hokuyo_urg04lx", "z": 0.2})
    assert urg.samples == 683
    assert urg.range_max == 5.6
    assert urg.z == 0.2
    assert math.isclose(urg.angle_max - urg.angle_min, math.radians(240))
    assert set(LASER_PRESETS) == {"sick_s300", "hokuyo_urg04lx", "hokuyo_ust10lx"}
    with pytest.raises(ConfigError, match="model"):
        load_laser_params({"model": "nope"})
    with pytest.raises(ConfigError, match="angle_max"):
        load_laser_params({"angle_min": 1.0, "angle_max": 0.5})
