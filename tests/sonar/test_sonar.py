"""The sonar ring (robot_side/sonar, robot_side/sim/sonar.py): the P3-AT's geometry, echoes as points in the
base frame, the simulated ring in both engines, a costmap marked behind the robot and cleared along a sonar
with no echo, and the sonar_cloud node on a real loopback bus."""

from __future__ import annotations

import dataclasses
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from common.config import ConfigError
from common.geometry import Pose2D
from common.messages import Header, PointCloud, SonarArray
from master_side.costmap.cost_values import FREE_SPACE, LETHAL, NO_INFORMATION
from master_side.costmap.costmap2d import Costmap2D
from master_side.costmap.footprint import pad_footprint
from master_side.costmap.layer_params import ObservationSourceParams, ObstacleLayerParams, VoxelLayerParams
from master_side.costmap.layered import LayeredCostmap
from master_side.costmap.obstacle_layer import ObstacleLayer
from master_side.costmap.voxel_layer import VoxelLayer
from robot_side.sim.simulator import Simulator
from robot_side.sonar.geometry import P3AT_SONARS, SonarRingParams, cone_points, sonar_points
from tests.support import free_port, wait_until

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "costmap"))
from costmap_helpers import obstacle_layer  # noqa: E402

RING = SonarRingParams()  # the P3-AT's 16 sonars, 15 deg cones, 5 m
# zenav's local costmap while mapping, in short: a laser source and the sonar source filling in
LASER = ObservationSourceParams(data_type="LaserScan", obstacle_range=2.5, raytrace_range=3.0, min_obstacle_height=-1.0)
SONAR = ObservationSourceParams(data_type="PointCloud", obstacle_range=1.5, raytrace_range=3.0, min_obstacle_height=0.0,
                                min_mark_separation=0.2)


def laser_and_sonar(footprint: np.ndarray | None = None,
                    sonar: ObservationSourceParams = SONAR) -> tuple[LayeredCostmap, ObstacleLayer]:
    """A 4 m rolling costmap at 0.025 m with one obstacle layer over LASER and ``sonar``; footprint clearing
    when a footprint is given."""
    lc = LayeredCostmap(Costmap2D(160, 160, 0.025, -2.0, -2.0), rolling_window=True, footprint=footprint)
    params = ObstacleLayerParams(footprint_clearing_enabled=footprint is not None)
    return lc, lc.add_layer(ObstacleLayer("obstacles", params, {"laser": LASER, "sonar": sonar}))


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


def test_an_echo_behind_marks_the_costmap_and_a_sonar_without_echo_clears_along_its_axis():
    lc = LayeredCostmap(Costmap2D(160, 160, 0.025, -2.0, -2.0), rolling_window=True)
    layer = obstacle_layer(lc, data_type="PointCloud", obstacle_range=1.5, raytrace_range=3.0,
                           min_obstacle_height=0.0)
    robot = Pose2D(0.0, 0.0, 0.0)
    ranges = [RING.range_max] * 16
    ranges[11] = 0.6
    pts = sonar_points(RING, ranges, z=0.2, max_range=RING.range_max * 1.001).astype(float)
    layer.add_observation("scan", pts, np.array([0.0, 0.0, 0.2]), 0.0)
    lc.update_map(robot)
    hit = pts[np.argmin(np.hypot(pts[:, 0] + 0.8, pts[:, 1]))]
    assert lc.master.get_cost(hit[0], hit[1]) == LETHAL
    far = [p for p in pts if np.hypot(p[0], p[1]) > 4.0]  # the 15 sonars without echo: beyond obstacle_range
    assert len(far) == 15 and all(lc.master.get_cost(p[0] * 0.35, p[1] * 0.35) != LETHAL for p in far)
    # the obstacle goes: sonar 11 hears nothing, and its axis is cleared
    ranges[11] = RING.range_max
    pts = sonar_points(RING, ranges, z=0.2, max_range=RING.range_max * 1.001).astype(float)
    layer.add_observation("scan", pts, np.array([0.0, 0.0, 0.2]), 1.0)
    lc.update_map(robot)
    assert lc.master.get_cost(hit[0], hit[1]) == FREE_SPACE


def test_cone_points_span_each_cone_just_short_of_its_reading():
    ranges = [RING.range_max] * 16
    ranges[11] = 0.6
    pts = cone_points(RING, ranges, use=(10, 11), rays=5, z=0.2)
    assert pts.dtype == np.float32 and pts.shape == (10, 3)
    x, y, h = RING.units[11]
    mine = pts[5:]  # sonar 11's, after sonar 10's
    d = np.hypot(mine[:, 0] - x, mine[:, 1] - y)
    assert np.allclose(d, 0.55, atol=1e-5)  # 0.05 m short of the echo
    bearings = np.arctan2(mine[:, 1] - y, mine[:, 0] - x)
    spread = np.angle(np.exp(1j * (bearings - h)))
    assert np.allclose(np.sort(spread), np.linspace(-RING.fov / 2, RING.fov / 2, 5), atol=1e-5)
    assert np.allclose(np.hypot(pts[:5, 0] - RING.units[10][0], pts[:5, 1] - RING.units[10][1]), RING.range_max - 0.05,
                       atol=1e-5)  # no echo: out to the ring's range
    assert len(cone_points(RING, [math.nan, 0.03] + [1.0] * 14, use=(0, 1))) == 0  # unusable, or nearer than short


def test_with_unknown_tracked_a_cone_heard_empty_is_known_free_across_not_only_on_its_axis():
    lc = LayeredCostmap(Costmap2D(160, 160, 0.025, -2.0, -2.0), rolling_window=True, track_unknown_space=True)
    cone_src = ObservationSourceParams(data_type="PointCloud", obstacle_range=1.5, raytrace_range=3.0,
                                       min_obstacle_height=0.0, marking=False, clearing=True)
    layer = lc.add_layer(ObstacleLayer("obstacles", ObstacleLayerParams(track_unknown_space=True),
                                       {"sonar": dataclasses.replace(SONAR, clearing=True), "cone": cone_src}))
    ranges = [RING.range_max] * 16
    ranges[11] = 1.0
    robot = Pose2D(0.0, 0.0, 0.0)
    origin = np.array([0.0, 0.0, 0.2])
    x, y, h = RING.units[11]
    # the cone's cells from 0.3 m to 0.9 m out, off its axis (more than 2 deg from it)
    d, a = np.meshgrid(np.linspace(0.3, 0.9, 25), np.radians(np.linspace(-7.0, 7.0, 29)))
    off = np.abs(a) > np.radians(2.0)
    sector = np.column_stack((x + d[off] * np.cos(h + a[off]), y + d[off] * np.sin(h + a[off])))

    def free_share() -> float:
        return float(np.mean([lc.master.get_cost(px, py) == FREE_SPACE for px, py in sector]))

    layer.add_observation("sonar", sonar_points(RING, ranges, use=(11,), z=0.2).astype(float), origin, 0.0)
    lc.update_map(robot)
    axis_only = free_share()
    assert axis_only < 0.2  # the axis alone leaves the cone unknown
    layer.add_observation("cone", cone_points(RING, ranges, use=(11,), rays=16, z=0.2).astype(float), origin, 1.0)
    lc.update_map(robot)
    assert free_share() > 0.9
    assert lc.master.get_cost(x + 1.0 * math.cos(h), y + 1.0 * math.sin(h)) == LETHAL  # the echo itself stays
    assert lc.master.get_cost(1.5, 1.5) == NO_INFORMATION  # where no sonar looked


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


def test_cleared_from_the_base_centre_a_side_sonar_erases_a_corner_outside_its_cone():
    """Sonar 8 (right flank, facing -90 deg) hears a wall 0.3 m out on its axis. A wall corner 8 cm beside the
    body, 16 deg off that axis, is outside its 15 deg cone: cleared from the sonar's own position it stays;
    cleared from the base's centre, the line to a cone point crosses it (what struck office02's door jamb)."""
    x8, y8, h8 = RING.units[8]
    ranges = [RING.range_max] * 16
    ranges[8] = 0.3
    cone = cone_points(RING, ranges, (8,), rays=16, z=0.2)
    corner = (-0.09, -0.33)  # 8 cm right of the body (half width 0.254), ahead of sonar 8's axis (x = -0.144)
    bearing = math.degrees(math.atan2(corner[1] - y8, corner[0] - x8)) - math.degrees(h8)
    assert abs(bearing) > 7.5  # outside the cone
    cone_source = dataclasses.replace(SONAR, marking=False, clearing=True, min_mark_separation=0.0)
    for origin, kept in (((x8, y8), True), ((0.0, 0.0), False)):
        lc = LayeredCostmap(Costmap2D(160, 160, 0.025, -2.0, -2.0), rolling_window=True)
        layer = lc.add_layer(ObstacleLayer("obstacles", ObstacleLayerParams(footprint_clearing_enabled=False),
                                           {"laser": LASER, "cone": cone_source}))
        layer.add_observation("laser", np.array([[corner[0], corner[1], 0.3]]), np.array([0.2, 0.0, 0.3]), 0.0)
        lc.update_map(Pose2D(0.0, 0.0, 0.0))
        assert lc.master.get_cost(*corner) == LETHAL
        layer.add_observation("laser", np.zeros((0, 3)), np.array([0.2, 0.0, 0.3]), 1.0)
        layer.add_observation("cone", cone, np.array([origin[0], origin[1], 0.2]), 1.0)
        lc.update_map(Pose2D(0.0, 0.0, 0.0))
        assert (lc.master.get_cost(*corner) == LETHAL) == kept, origin


@pytest.mark.parametrize("fov", [0.0, math.radians(15.0)])
def test_a_sonar_echo_marks_only_what_the_marks_near_it_do_not_explain(fov):
    """min_mark_separation: an echo of a wall the laser has marked adds nothing, also one placed on the sonar's
    axis in front of an oblique wall (a displaced second wall narrowed office02's passages until no trajectory
    was left: the wall's marks in the window, its nearest point in the cone among them, lie no farther than
    the echo); an echo where nothing is marked does, and so does one nearer than every mark around it by more
    than a cell (the wall was marked before the odometry slipped: on physics, office02's rear corners struck
    walls marked 3-7 cm farther than they were); one a cell nearer does not (a sonar's noise)."""
    lc, layer = laser_and_sonar(sonar=dataclasses.replace(SONAR, min_mark_separation_fov=fov))
    wall = np.column_stack((np.full(41, 0.5), np.linspace(-0.5, 0.5, 41), np.zeros(41)))  # x = 0.5, y -0.5..0.5
    # an oblique wall behind the robot: from (-0.3, -0.9) to (-0.9, -0.3), at 45 deg to the sonar's axis below
    oblique = np.column_stack((np.linspace(-0.3, -0.9, 41), np.linspace(-0.9, -0.3, 41), np.zeros(41)))
    layer.add_observation("laser", np.vstack((wall, oblique)), np.array([0.0, 0.0, 0.3]), 0.0)
    origin = np.array([0.0, 0.0, 0.2])
    # the oblique wall's nearest point within 7.5 deg of the axis at -105 deg (its normal is at -135 deg, 0.85 m)
    axis, normal, d = math.radians(-105.0), math.radians(-135.0), 1.2 / math.sqrt(2.0)
    r = d / math.cos(normal - axis + math.radians(7.5))
    on_axis = [r * math.cos(axis), r * math.sin(axis)]
    echoes = np.array([[0.495, 0.2, 0.2],  # the laser's wall, 5 mm short (sonar noise)
                       [*on_axis, 0.2],   # in front of the oblique wall, on the axis: its nearest point explains it
                       [-0.6, 0.3, 0.2],  # nothing else saw it
                       [0.44, -0.05, 0.2],  # 6 cm nearer than the laser's wall: it is nearer now
                       [0.49, 0.0, 0.2]])  # head-on, the cell in front of the wall's (one cell nearer): noise
    layer.add_observation("sonar", echoes, origin, 0.0)
    lc.update_map(Pose2D(0.0, 0.0, 0.0))
    assert lc.master.get_cost(0.5, 0.2) == LETHAL  # the laser's wall
    assert lc.master.get_cost(0.495, 0.2) != LETHAL  # no second wall in the cell in front of it
    assert d - r * math.cos(normal - axis) > 0.05  # the axis point lies 5 cm in front of the wall
    assert lc.master.get_cost(*on_axis) != LETHAL
    assert lc.master.get_cost(-0.6, 0.3) == LETHAL  # the echo nothing else saw
    assert lc.master.get_cost(0.44, -0.05) == LETHAL  # nearer than the marks: marked
    assert lc.master.get_cost(0.49, 0.0) != LETHAL  # one cell nearer (centre to centre): not
    with pytest.raises(ValueError, match="min_mark_separation"):
        VoxelLayer("voxels", VoxelLayerParams(), {"sonar": SONAR})


def test_with_the_cone_only_marks_inside_it_explain_an_echo():
    """min_mark_separation_fov: the echo of a wall's end (a door jamb ahead and to the left) is hidden by the
    marks of the same wall nearer the sonar in the square window, though they lie outside the sonar's 15 deg
    cone and it cannot have heard them; with the cone, only marks inside it count, and the end is marked
    (office02, the Kinect robot: its flank struck that jamb turning round it). A mark inside the cone, nearer
    than the echo, still explains it."""
    wall = np.column_stack((np.arange(-0.3, 0.2001, 0.025), np.full(21, 0.41), np.zeros(21)))  # marked to x = 0.2
    origin = np.array([0.147, 0.136, 0.2])  # sonar 0's place, left front
    echo = np.array([[0.3, 0.41, 0.2]])  # the wall's end, 0.1 m past its marks, 61 deg from the sonar
    for fov, marked in ((0.0, False), (math.radians(15.0), True)):
        lc, layer = laser_and_sonar(sonar=dataclasses.replace(SONAR, min_mark_separation_fov=fov))
        layer.add_observation("laser", wall, np.array([-0.5, 0.0, 0.3]), 0.0)
        layer.add_observation("sonar", echo, origin, 0.0)
        lc.update_map(Pose2D(0.0, 0.0, 0.0))
        assert lc.master.get_cost(0.2, 0.41) == LETHAL  # 0.28 m from the sonar, 18 deg off the echo's line
        assert (lc.master.get_cost(0.3, 0.41) == LETHAL) == marked, fov
    lc, layer = laser_and_sonar(sonar=dataclasses.replace(SONAR, min_mark_separation_fov=math.radians(15.0)))
    layer.add_observation("laser", np.array([[0.27, 0.37, 0.3]]), np.array([-0.5, 0.0, 0.3]), 0.0)  # in the cone
    layer.add_observation("sonar", echo, origin, 0.0)
    lc.update_map(Pose2D(0.0, 0.0, 0.0))
    assert lc.master.get_cost(0.3, 0.41) != LETHAL


def test_marks_under_the_footprint_do_not_hide_an_echo_beside_the_robots_corner():
    """A wall 0.03 m beside the robot lies under its padded footprint, which the layer frees each update; an echo
    of the same wall just behind the rear corner (outside the footprint) must still mark, or nothing stops the
    planner sweeping the corner into it (office02: five rear-corner contacts in 20 s along one wall)."""
    body = np.array([[0.254, 0.254], [-0.254, 0.254], [-0.254, -0.254], [0.254, -0.254]])
    lc, layer = laser_and_sonar(footprint=pad_footprint(body, 0.04))
    beside = np.column_stack((np.linspace(-0.2, 0.2, 17), np.full(17, -0.284), np.zeros(17)))  # 0.03 m off
    layer.add_observation("laser", beside, np.array([0.1, 0.0, 0.3]), 0.0)
    echo = np.array([[-0.32, -0.27, 0.2]])  # sonar 9's echo of that wall, behind the rear right corner
    layer.add_observation("sonar", echo, np.array([0.0, 0.0, 0.2]), 0.0)
    lc.update_map(Pose2D(0.0, 0.0, 0.0))
    assert lc.master.get_cost(0.0, -0.284) == FREE_SPACE  # under the padded footprint: freed (as ROS)
    assert lc.master.get_cost(-0.32, -0.27) == LETHAL  # the echo outside it stays


def test_a_sonar_echo_within_the_padding_beside_the_flank_survives_footprint_clearing():
    """footprint_clearing: false on the sonar source: an echo 3 cm from the flank (inside the padded footprint,
    outside the robot's own outline) stays marked; one under the body is freed; a laser mark there is freed."""
    body = np.array([[0.254, -0.254], [0.254, 0.254], [-0.254, 0.254], [-0.254, -0.254]])
    padded = pad_footprint(body, 0.04)
    near = np.array([[-0.1, -0.284, 0.2]])  # the right flank, rear half, 3 cm out
    under = np.array([[0.0, -0.2, 0.2]])  # under the body
    for keep in (False, True):
        lc = LayeredCostmap(Costmap2D(160, 160, 0.025, -2.0, -2.0), rolling_window=True, footprint=padded,
                            footprint_padding=0.04)
        sonar = dataclasses.replace(SONAR, footprint_clearing=not keep)
        layer = lc.add_layer(ObstacleLayer("obstacles", ObstacleLayerParams(footprint_clearing_enabled=True),
                                           {"laser": LASER, "sonar": sonar}))
        layer.add_observation("laser", np.array([[0.1, 0.28, 0.3]]), np.array([0.2, 0.0, 0.3]), 0.0)
        layer.add_observation("sonar", np.vstack((near, under)), np.array([0.0, 0.0, 0.2]), 0.0)
        lc.update_map(Pose2D(0.0, 0.0, 0.0))
        assert lc.master.get_cost(-0.1, -0.284) == (LETHAL if keep else FREE_SPACE), keep
        assert lc.master.get_cost(0.0, -0.2) == FREE_SPACE  # the robot is there
        assert lc.master.get_cost(0.1, 0.28) == FREE_SPACE  # the laser's mark within the padding: freed as in ROS


def test_when_no_source_frees_the_padding_a_wall_seen_earlier_beside_the_flank_stays():
    """Every marking source footprint_clearing: false: the layer frees only the cells under the robot's body, so
    a wall the laser marked ahead and the robot then drew level with (3 cm from its flank, in the padding, out
    of the laser's view) stays marked though no reading holds it any more, and so does one touching the other
    flank (its cell crossed by the outline); under the body a mark is freed."""
    body = np.array([[0.254, -0.254], [0.254, 0.254], [-0.254, 0.254], [-0.254, -0.254]])
    lc = LayeredCostmap(Costmap2D(160, 160, 0.025, -2.0, -2.0), rolling_window=True,
                        footprint=pad_footprint(body, 0.04), footprint_padding=0.04)
    laser = dataclasses.replace(LASER, footprint_clearing=False)
    sonar = dataclasses.replace(SONAR, footprint_clearing=False)
    layer = lc.add_layer(ObstacleLayer("obstacles", ObstacleLayerParams(footprint_clearing_enabled=True),
                                       {"laser": laser, "sonar": sonar}))
    wall = np.array([[x, -0.284, 0.3] for x in np.arange(0.4, 1.6, 0.02)])  # ahead, on the right
    touching = np.array([[x, 0.258, 0.3] for x in np.arange(0.4, 1.6, 0.02)])  # on the left, 4 mm off the body
    layer.add_observation("laser", np.vstack((wall, touching)), np.array([0.0, 0.0, 0.3]), 0.0)
    layer.add_observation("sonar", np.zeros((0, 3)), np.array([0.0, 0.0, 0.2]), 0.0)
    lc.update_map(Pose2D(0.0, 0.0, 0.0))
    layer.add_observation("laser", np.zeros((0, 3)), np.array([0.8, 0.0, 0.3]), 1.0)  # nothing seen now
    lc.update_map(Pose2D(0.7, 0.0, 0.0))  # drawn level with the wall
    assert lc.master.get_cost(0.7, -0.284) == LETHAL  # 3 cm from the flank: kept
    assert lc.master.get_cost(1.3, -0.284) == LETHAL
    assert lc.master.get_cost(0.7, 0.258) == LETHAL  # in the cell the outline crosses: the flank touches it
    lc.update_map(Pose2D(0.7, -0.1, 0.0))  # the robot on the wall (as a bad pose would put it)
    assert lc.master.get_cost(0.7, -0.284) == FREE_SPACE  # under the body: freed


def test_the_cone_option_without_the_window_is_refused():
    with pytest.raises(ValueError, match="min_mark_separation_fov needs min_mark_separation"):
        ObservationSourceParams(min_mark_separation_fov=0.26).validate()


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
