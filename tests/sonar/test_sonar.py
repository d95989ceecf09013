"""The sonar ring (robot_side/sonar, robot_side/sim/sonar.py): the P3-AT's geometry, echoes as points in the
base frame, and the simulated ring in both engines, cast fan by fan or all at once. The costmap's use of the
echoes is in test_sonar_costmap.py, the sonar_cloud node on a real bus in test_sonar_node.py."""

from __future__ import annotations

import math

import numpy as np
import pytest

from common.config import ConfigError
from common.geometry import Pose2D
from robot_side.sim.simulator import Simulator
from robot_side.sonar.geometry import P3AT_SONARS, SonarRingParams, sonar_points

RING = SonarRingParams()  # the P3-AT's 16 sonars, 15 deg cones, 5 m


def test_the_p3at_ring_is_eight_front_and_eight_rear_mirrored_left_to_right():
    assert [n for n, *_ in P3AT_SONARS] == list(range(16))
    front, rear = P3AT_SONARS[:8], P3AT_SONARS[8:]
    assert all(x > 0 for _, x, _, _ in front) and all(x < 0 for _, x, _, _ in rear)
    for (_, x, y, h), (_, x2, y2, h2) in zip(front, reversed(front)):
        assert (x, y, h) == (x2, -y2, -h2)
    assert [h for *_, h in rear] == [-90, -130, -150, -170, 170, 150, 130, 90]  # right to left behind


def test_an_echo_is_a_point_on_the_sonars_axis_and_no_echo_gives_none():
    ranges = [RING.range_max] * 16
    ranges[11], ranges[0] = 0.5, 1.0
    pts = sonar_points(RING, ranges, z=0.2)
    assert pts.dtype == np.float32 and pts.shape == (2, 3)
    x, y, h = RING.units[11]
    assert np.allclose(pts[1], [x + 0.5 * math.cos(h), y + 0.5 * math.sin(h), 0.2], atol=1e-6)
    assert np.allclose(pts[0], [0.147, 0.136 + 1.0, 0.2], atol=1e-6)  # sonar 0 looks left (+y)
    assert len(sonar_points(RING, ranges, use=(8, 9, 10))) == 0  # not the rear sonars that echoed
    assert len(sonar_points(RING, ranges, use=(11,))) == 1
    with_far = sonar_points(RING, ranges, max_range=RING.range_max * 1.001)  # no-echo readings kept too
    assert len(with_far) == 16
    bad = [math.inf, math.nan, -1.0, 0.0] + [RING.range_max] * 12
    assert len(sonar_points(RING, bad)) == 0


@pytest.mark.parametrize("engine", ["kinematic", "mujoco"])
def test_the_simulated_ring_hears_a_box_behind_the_robot_where_the_laser_cannot_see(engine):
    if engine == "mujoco":
        pytest.importorskip("mujoco")
    sim = Simulator.from_config({"world": "room", "start": [-1.0, 0.0, 0.0], "laser": None, "depth_camera": None,
                                 "engine": engine, "sonar": {"noise_std": 0.0}})
    before = sim.sonar_reading()
    assert len(before.ranges) == 16 and before.header.frame_id == "base_link"
    sim.add_box(-1.0 - 0.254 - 0.4 - 0.1, 0.0, 0.2, 1.0, 0.5)  # 1 m wide, its face 0.4 m behind the rear
    after = sim.sonar_reading().ranges
    # sonars 11 and 12 (x = -0.241, heading +-170 deg) hear the face 0.413 m away along the cone's nearest ray
    for i in (11, 12):
        assert after[i] == pytest.approx(0.413 / math.cos(math.radians(10 - 7.5)), abs=0.01), (i, after)
    for i in range(8):  # the front ring hears nothing new
        assert after[i] == pytest.approx(before.ranges[i], abs=1e-6)


def test_sonar_parameters_out_of_range_name_the_key():
    with pytest.raises(ConfigError) as e:
        Simulator.from_config({"world": "room", "laser": None, "depth_camera": None, "sonar": {"fov": 5.0}},
                              "robot.yaml")
    assert "sonar.fov" in str(e.value) and "robot.yaml" in str(e.value)
    with pytest.raises(ConfigError) as e:
        Simulator.from_config({"world": "room", "laser": None, "depth_camera": None, "sonar": {"rayz": 3}})
    assert "rayz" in str(e.value)
    with pytest.raises(ConfigError) as e:
        Simulator.from_config({"world": "room", "laser": None, "depth_camera": None, "sonar": 5})
    assert "sonar" in str(e.value) and "mapping" in str(e.value)



@pytest.mark.parametrize("world", ["room", "office02"])
def test_the_ring_cast_at_once_gives_each_fans_own_cast_to_the_bit(world, shared_dir):
    """``sim.sonar.nearest_hits`` (every fan in one compiled loop) against each fan's own
    ``Laser.ranges_exact``, at 400 random poses over the whole world (inside walls too), exactly equal."""
    from robot_side.sim.sonar import nearest_hits

    if world == "office02":
        world = str(shared_dir / "datasets" / "mrpb" / "maps" / "office02" / "map.yaml")
    sim = Simulator.from_config({"world": world, "start": [0.0, 0.0, 0.0], "laser": None, "depth_camera": None,
                                 "sonar": {"noise_std": 0.0}})
    fans, w = sim.sonar.fans, sim.world
    h, wd = w.heights.shape
    rng = np.random.default_rng(7)
    echoes = 0
    for _ in range(400):
        pose = Pose2D(w.origin[0] + rng.uniform(0, wd * w.resolution), w.origin[1] + rng.uniform(0, h * w.resolution),
                      rng.uniform(-math.pi, math.pi))
        each = np.array([float(np.min(f.ranges_exact(pose))) for f in fans])
        assert np.array_equal(nearest_hits(fans, pose), each), pose
        echoes += int(np.isfinite(each).sum())
    assert echoes > 400 * 16 // 2  # most cones hear a wall: the comparison is not of empty results
