"""The sonar_cloud node (robot_side/sonar/node.py) on a real loopback bus: readings in, echoes and cones out as
point clouds in the base frame or one per sonar in its own frame, placed by static TF."""

from __future__ import annotations

import numpy as np
import pytest

from common.config import ConfigError
from common.messages import Header, PointCloud, SonarArray
from robot_side.sonar.geometry import SonarRingParams, cone_points, sonar_points
from tests.support import free_port, wait_until

RING = SonarRingParams()  # the P3-AT's 16 sonars, 15 deg cones, 5 m


@pytest.fixture
def peers(robot_name):
    from common.bus import Node
    from common.zenoh_config import BusConfig

    ep = (f"tcp/127.0.0.1:{free_port()}",)
    a = Node("sonar_test", config=BusConfig(robot=robot_name, listen=ep, multicast=False), use_sim_time=False)
    b = Node("sonar_cloud", config=BusConfig(robot=robot_name, connect=ep, multicast=False), use_sim_time=False)
    yield a, b
    b.close()
    a.close()


def test_the_sonar_cloud_node_turns_readings_into_points_on_the_bus(peers):
    from robot_side.sonar.node import start

    test, host = peers
    handles = start(host, {"use": [8, 9, 10, 11, 12, 13, 14, 15], "include_no_echo": False,
                           "cone_topic": "sonar_cone_pointcloud", "cone_rays": 3}, "sonar.yaml")
    try:
        clouds = test.subscribe("sonar_pointcloud", PointCloud)
        cones = test.subscribe("sonar_cone_pointcloud", PointCloud)
        pub = test.publisher("sonar")
        ranges = [RING.range_max] * 16
        ranges[3], ranges[12] = 0.5, 0.7  # a front echo (not used) and a rear one

        def got():
            pub.publish(SonarArray(Header(12.5, "base_link"), tuple(ranges)))
            c = clouds.latest()
            return c if c is not None and len(c.points) else None

        cloud = wait_until(got, 20, "a sonar point cloud")
        assert cloud.header == Header(12.5, "base_link")
        assert cloud.points.shape == (1, 3)
        assert np.allclose(cloud.points[0], sonar_points(RING, ranges, use=(12,))[0])
        cone = wait_until(lambda: got() and cones.latest(), 20, "a sonar cone cloud")
        assert cone.points.shape == (8 * 3, 3)  # every rear cone, echo or not, 3 bearings each
        assert np.allclose(cone.points, cone_points(RING, ranges, (8, 9, 10, 11, 12, 13, 14, 15), rays=3))
    finally:
        handles.close()
    handles = start(host, {"use": [8], "cone_topic": "sonar_cones_all", "cone_use": [], "cone_rays": 1}, "sonar.yaml")
    try:
        every = test.subscribe("sonar_cones_all", PointCloud)
        assert wait_until(lambda: got() and every.latest(), 20, "all cones").points.shape == (16, 3)
    finally:
        handles.close()
    handles = start(host, {"use": [3, 12], "near": [3], "near_range": 0.5, "include_no_echo": False,
                           "points_topic": "near_points"}, "sonar.yaml")
    try:  # sonar 3 is near-only: its echo at 0.5 m or beyond gives no point, nearer it does; sonar 12 always
        near = test.subscribe("near_points", PointCloud)
        for r3, expect in ((0.5, 1), (0.45, 2)):
            ranges[3] = r3
            cloud = wait_until(lambda n=expect: got() and (c := near.latest()) is not None and len(c.points) == n
                               and c, 20, f"sonar 3 at {r3} m")
            assert np.allclose(cloud.points, sonar_points(RING, ranges, use=(3, 12) if expect == 2 else (12,)))
    finally:
        handles.close()
    with pytest.raises(ConfigError) as e:
        start(host, {"use": "rear"}, "sonar.yaml")
    assert "use" in str(e.value)


def test_with_a_frame_prefix_each_sonar_is_a_cloud_in_its_own_frame_placed_by_static_tf(peers):
    """frame_prefix: one cloud per sonar and reading, in sonar_<k> (its point on its x axis at the reading),
    and the static transforms that put sonar_<k> on the ring; a costmap then raytraces from the sonar."""
    from common.tf import TFListener
    from robot_side.sonar.node import start

    test, host = peers
    handles = start(host, {"use": [8, 12], "include_no_echo": False, "cone_topic": "cones", "cone_rays": 3,
                           "frame_prefix": "sonar_"}, "sonar.yaml")
    tf = TFListener(test)
    try:
        seen: dict[str, PointCloud] = {}
        test.subscribe("sonar_pointcloud", PointCloud, mode="queue",
                       callback=lambda m: seen.__setitem__(m.header.frame_id, m))
        cones: dict[str, PointCloud] = {}
        test.subscribe("cones", PointCloud, mode="queue", callback=lambda m: cones.__setitem__(m.header.frame_id, m))
        pub = test.publisher("sonar")
        ranges = [RING.range_max] * 16
        ranges[12] = 0.7

        def got():
            pub.publish(SonarArray(Header(3.0, "base_link"), tuple(ranges)))
            return {"sonar_8", "sonar_12"} <= set(seen) and {"sonar_8", "sonar_12"} <= set(cones) \
                and tf.buffer.can_transform("base_link", "sonar_12", 0.0)

        wait_until(got, 20, "one cloud per sonar and the sonars' frames")
        assert set(seen) == {"sonar_8", "sonar_12"}  # only the used sonars
        assert seen["sonar_8"].points.shape == (0, 3)  # no echo
        assert np.allclose(seen["sonar_12"].points, [[0.7, 0.0, 0.0]], atol=1e-6)
        assert cones["sonar_12"].points.shape == (3, 3) and np.allclose(cones["sonar_12"].points[:, 0].max(), 0.65)
        x, y, h = RING.units[12]
        in_base = tf.buffer.transform_points("base_link", "sonar_12", seen["sonar_12"].points.astype(float))
        assert np.allclose(in_base, sonar_points(RING, ranges, use=(12,), z=0.2), atol=1e-5)
        assert np.allclose(tf.buffer.lookup_pose2d("base_link", "sonar_12").as_array(), [x, y, h], atol=1e-6)
    finally:
        tf.close()
        handles.close()
