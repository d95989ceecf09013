import numpy as np
from costmap_helpers import beam, layered, obstacle_layer, ring_scan

from common.geometry import Pose2D
from common.messages import LaserScan
from master_side.costmap.cost_values import FREE, LETHAL, NO_INFORMATION
from master_side.costmap.observation import scan_to_points


def test_ray_tracing_clears_free_space_up_to_the_hit():
    lc = layered(4.0, 0.1, track_unknown=True)
    ob = obstacle_layer(lc, track_unknown=True)
    pts, origin = beam((0.55, 1.05), (2.55, 1.05))
    ob.add_observation("scan", pts, origin, 0.0)
    lc.update_map(Pose2D(0.55, 1.05, 0.0))
    row = lc.master.data[10]
    assert np.all(row[5:25] == FREE)
    assert row[25] == LETHAL
    assert np.all(row[26:] == NO_INFORMATION)
    assert np.all(lc.master.data[12] == NO_INFORMATION)


def test_diagonal_rays_clear_a_connected_line():
    lc = layered(4.0, 0.1, track_unknown=True)
    ob = obstacle_layer(lc, track_unknown=True, obstacle_range=5.0, raytrace_range=5.0)
    pts, origin = beam((0.05, 0.05), (3.05, 2.05))
    ob.add_observation("scan", pts, origin, 0.0)
    lc.update_map(Pose2D(0.05, 0.05, 0.0))
    free = lc.master.data == FREE
    assert free[0, 0]
    assert lc.master.data[20, 30] == LETHAL
    cols_with_free = np.nonzero(free.any(axis=0))[0]
    assert list(cols_with_free) == list(range(30))  # every column up to the hit is crossed


def test_obstacles_beyond_obstacle_range_are_not_marked_and_beyond_raytrace_range_not_cleared():
    lc = layered(6.0, 0.1, track_unknown=True)
    ob = obstacle_layer(lc, track_unknown=True, obstacle_range=2.0, raytrace_range=3.0)
    pts, origin = beam((0.55, 3.05), (4.55, 3.05))  # hit 4 m away
    ob.add_observation("scan", pts, origin, 0.0)
    lc.update_map(Pose2D(0.55, 3.05, 0.0))
    row = lc.master.data[30]
    assert not np.any(row == LETHAL)
    assert np.all(row[5:35] == FREE)  # cleared out to 3 m
    assert np.all(row[36:] == NO_INFORMATION)


def test_points_outside_the_height_band_are_not_marked():
    lc = layered(4.0, 0.1)
    ob = obstacle_layer(lc, min_obstacle_height=0.1, max_obstacle_height=1.0, clearing=False)
    pts = np.array([[1.05, 1.05, 0.05], [2.05, 1.05, 0.5], [3.05, 1.05, 1.5]])
    ob.add_observation("scan", pts, np.array([0.05, 1.05, 0.5]), 0.0)
    lc.update_map(Pose2D(0.05, 1.05, 0.0))
    assert lc.master.data[10, 10] == FREE
    assert lc.master.data[10, 20] == LETHAL
    assert lc.master.data[10, 30] == FREE


def test_an_obstacle_removed_from_the_scene_is_cleared_within_a_few_scans():
    lc = layered(4.0, 0.05)
    ob = obstacle_layer(lc)
    robot = (2.02, 2.02)
    ranges = np.full(360, 1.5)
    ranges[170:190] = 0.8  # a box 0.8 m ahead of the robot (beams near angle 0)
    ob.add_observation("scan", ring_scan(robot, ranges), np.array([*robot, 0.2]), 0.0)
    lc.update_map(Pose2D(*robot, 0.0))
    assert lc.master.get_cost(robot[0] + 0.8, robot[1]) == LETHAL
    for i in range(1, 4):  # the box is gone: the beams now reach the wall behind it
        ob.add_observation("scan", ring_scan(robot, np.full(360, 1.5)), np.array([*robot, 0.2]), 0.1 * i)
        lc.update_map(Pose2D(*robot, 0.0))
    assert lc.master.get_cost(robot[0] + 0.8, robot[1]) == FREE
    assert lc.master.get_cost(robot[0] + 1.5, robot[1]) == LETHAL


def test_an_obstacle_out_of_sensor_range_is_remembered():
    lc = layered(8.0, 0.1)
    ob = obstacle_layer(lc, obstacle_range=2.5, raytrace_range=3.0)
    pts, origin = beam((1.0, 4.0), (2.05, 4.05))
    ob.add_observation("scan", pts, origin, 0.0)
    lc.update_map(Pose2D(1.0, 4.0, 0.0))
    assert lc.master.get_cost(2.05, 4.05) == LETHAL
    # the robot drives away; its scans (short range, all directions) no longer reach the obstacle
    for i, x in enumerate((3.0, 5.0, 7.0)):
        ob.add_observation("scan", ring_scan((x, 6.0), np.full(90, 0.8)), np.array([x, 6.0, 0.2]), 1.0 + i)
        lc.update_map(Pose2D(x, 6.0, 0.0))
    assert lc.master.get_cost(2.05, 4.05) == LETHAL


def test_footprint_clearing_frees_cells_under_the_robot():
    lc = layered(4.0, 0.1, robot_radius=0.3)
    ob = obstacle_layer(lc, footprint_clearing=True, clearing=False)
    pts = np.array([[2.05, 2.05, 0.2], [3.05, 2.05, 0.2]])
    ob.add_observation("scan", pts, np.array([1.0, 2.0, 0.2]), 0.0)
    lc.update_map(Pose2D(2.0, 2.0, 0.0))
    assert lc.master.get_cost(2.05, 2.05) == FREE
    assert lc.master.get_cost(3.05, 2.05) == LETHAL


def test_observation_persistence_keeps_recent_readings_only():
    lc = layered(4.0, 0.1)
    ob = obstacle_layer(lc, clearing=False, observation_persistence=1.0)
    for t in (0.0, 0.5, 2.0):
        ob.add_observation("scan", np.array([[1.05, 1.05, 0.2]]), np.array([0.5, 1.0, 0.2]), t)
    assert [o.stamp for o in ob.buffers["scan"].observations] == [2.0]


def test_expected_update_rate_flags_a_late_source():
    lc = layered(4.0, 0.1)
    ob = obstacle_layer(lc, expected_update_rate=0.5)
    ob.add_observation("scan", np.zeros((0, 3)), np.zeros(3), 10.0)
    assert lc.is_current(10.4)
    assert not lc.is_current(10.6)
    assert lc.stale_sources(10.6) == ["obstacles/scan"]


def test_scan_to_points_handles_inf_as_ros_does():
    scan = LaserScan(angle_min=0.0, angle_increment=np.pi / 2, range_min=0.1, range_max=4.0,
                     ranges=np.array([1.0, np.inf, np.nan, 0.05], np.float32))
    assert len(scan_to_points(scan)) == 1
    pts = scan_to_points(scan, inf_is_valid=True)
    np.testing.assert_allclose(pts[1], [0.0, 4.0 - 1e-4, 0.0], atol=1e-6)


def test_conservative_reset_keeps_obstacles_near_the_robot_and_forgets_far_ones():
    lc = layered(6.0, 0.1)
    ob = obstacle_layer(lc)
    near, origin = beam((3.05, 3.05), (3.55, 3.05))  # hit 0.5 m from the robot
    far, _ = beam((3.05, 3.05), (5.05, 3.05))  # hit 2.0 m away
    ob.add_observation("scan", np.vstack((near[-1:], far[-1:])), origin, 0.0)
    lc.update_map(Pose2D(3.05, 3.05, 0.0))
    assert lc.master.data[30, 35] == LETHAL and lc.master.data[30, 50] == LETHAL
    lc.clear_outside(Pose2D(3.05, 3.05, 0.0), 2.0)
    lc.update_map(Pose2D(3.05, 3.05, 0.0))
    assert lc.master.data[30, 35] == LETHAL  # inside the 2 m square: kept
    assert lc.master.data[30, 50] != LETHAL  # outside: cleared
