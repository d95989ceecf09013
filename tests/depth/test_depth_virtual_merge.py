"""Virtual scans + scan merging: the tutorial's ira_laser_tools set-up against analytic scenes."""

from __future__ import annotations

import math

import numpy as np
import pytest
from depth_scene import Box, camera_info, floor, optical_pose, raycast_2d, render, wall_x

from common.config import ConfigError, load_params
from common.geometry import Transform, Vector3
from common.messages import DepthImage, Header, LaserScan
from robot_side.depth.cloud import depth_to_cloud
from robot_side.depth.depth_to_scan import DepthToScanParams, depth_to_scan
from robot_side.depth.merger import MergerParams, ScanMerger, merge_scans, scan_to_points
from robot_side.depth.virtualizer import (
    Virtualizer,
    VirtualizerParams,
    horizontal_planes,
    oblique_planes,
    tutorial_planes,
    virtualize,
)

CAM = Transform.from_xyz_rpy(0.0, 0.0, 0.5, 0.0, 0.0, 0.0)  # base_link <- camera_link, level
LOW_BOX = Box((1.5, -0.2, 0.0), (1.8, 0.2, 0.35))  # under the sensor, above the lowest plane
# Virtual rays (0.004 rad) no finer than the QVGA camera's columns (1 / 262.5 rad), merged rays no finer than
# the virtual ones: otherwise some rays get no point (as with the ROS nodes).
VP = VirtualizerParams(plane_half_thickness=0.02, range_min=0.1, angle_increment=0.004)
MP = MergerParams(angle_min=-1.0, angle_max=1.0, angle_increment=0.005, range_min=0.1, range_max=10.0)


def _bin_bounds(scan: LaserScan, tol: float, boxes: list[Box]) -> tuple[np.ndarray, np.ndarray]:
    """Analytic min / max planar range (from base origin) over the angles that may land on each ray.

    A return reaches merged ray i if its virtual ray is within half a merged increment of it, and
    the virtual ray is within half a virtual increment of the return's true bearing.
    """
    half = (scan.angle_increment + VP.angle_increment) / 2
    sub = scan.angles()[:, None] + np.linspace(-half, half, 13)[None, :]
    r = raycast_2d(boxes, (0.0, 0.0), sub.ravel()).reshape(sub.shape)
    return r.min(axis=1) - tol, r.max(axis=1) + tol


def test_low_box_is_seen_by_virtual_scans_and_merge_but_not_by_depth_to_scan():
    info = camera_info()
    scene = [LOW_BOX, wall_x(4.0), floor()]
    depth = render(scene, CAM, info)
    # depthimage_to_laserscan: the box is invisible.
    plain = depth_to_scan(DepthImage(Header(1.0, "opt"), depth), info, DepthToScanParams(scan_height=3))
    assert plain.ranges.min() > 3.9
    # Virtualizer + merger: the box is there, at its analytic range.
    planes = tutorial_planes(CAM)
    assert [round(p.translation.z, 3) for p in planes] == pytest.approx(np.linspace(0.25, 1.4, 8).round(3))
    cloud = depth_to_cloud(depth, info)
    scans = virtualize(cloud, planes, VP, stamp=1.0, cloud_to_base=optical_pose(CAM))
    assert len(scans) == 8
    low = scans[0]  # the plane 0.25 m above the floor crosses the box
    front = np.abs(low.angles()) < math.atan(0.19 / 1.5)
    assert np.all(np.abs(low.ranges[front] - 1.5 / np.cos(low.angles()[front])) < 0.02)
    assert np.all(scans[1].ranges[front] > 3.9)  # plane at 0.41 m: above the box
    merged, cloud_out = merge_scans(zip(scans, planes), MP)
    a = merged.angles()
    front = np.abs(a) < math.atan(0.19 / 1.5)
    assert np.all(np.abs(merged.ranges[front] - 1.5 / np.cos(a[front])) < 0.02)
    assert merged.header.frame_id == "base_link"
    assert merged.header.stamp == 1.0
    assert cloud_out.points.shape[1] == 3
    assert len(cloud_out.points) > 0


def test_merged_virtual_scans_match_a_wide_scan_of_the_scene():
    info = camera_info()
    half_fov = math.atan(info.cx / info.fx)
    boxes_in_planes = [LOW_BOX, Box((2.2, 0.4, 0.0), (2.6, 0.9, 1.0)),
                       Box((1.0, -1.0, 0.9), (1.4, -0.5, 1.2)), wall_x(4.0)]
    scene = boxes_in_planes + [floor(), Box((0.8, 0.3, 0.0), (1.0, 0.5, 0.1))]  # last: below every plane
    depth = render(scene, CAM, info)
    planes = tutorial_planes(CAM)
    scans = Virtualizer(planes, VP).scans(depth_to_cloud(depth, info), 2.0, optical_pose(CAM))
    merged, _ = merge_scans(zip(scans, planes), MP)
    a = merged.angles()
    inside = np.abs(a) < half_fov - 2 * MP.angle_increment
    outside = (a > half_fov + MP.angle_increment) | (a + MP.angle_increment < -half_fov)
    lo, hi = _bin_bounds(merged, 0.03, boxes_in_planes)
    r = merged.ranges
    assert np.all(np.isposinf(r[outside]))
    assert np.all(np.isfinite(r[inside]))
    assert np.all((r[inside] >= lo[inside]) & (r[inside] <= hi[inside]))


def test_invalid_pixels_never_become_obstacles_in_virtual_scans():
    info = camera_info()
    depth = render([wall_x(3.0), floor()], CAM, info)
    rng = np.random.default_rng(7)
    depth[rng.random(depth.shape) < 0.5] = 0.0
    depth[rng.random(depth.shape) < 0.2] = np.nan
    planes = tutorial_planes(CAM)
    scans = virtualize(depth_to_cloud(depth, info), planes, VP, cloud_to_base=optical_pose(CAM))
    merged, _ = merge_scans(zip(scans, planes), MP)
    finite = np.isfinite(merged.ranges)
    in_fov = np.abs(merged.angles()) < math.atan(info.cx / info.fx) - 0.01
    assert finite[in_fov].mean() > 0.9  # 8 planes x several rows: holes rarely empty a whole ray
    assert np.all(merged.ranges[finite] >= 3.0 - 0.01)


def test_points_outside_the_slab_and_range_limits_are_ignored():
    params = VirtualizerParams(angle_min=-math.pi, angle_max=math.pi, angle_increment=0.01,
                               range_min=0.5, range_max=5.0, plane_half_thickness=0.05)
    plane = [Transform.from_xyz_rpy(0.0, 0.0, 1.0, 0.0, 0.0, 0.0)]
    pts = np.array([[2.0, 0.0, 1.04],   # in the slab -> 2.0 at angle 0
                    [1.0, 0.0, 1.06],   # just outside the slab
                    [0.3, 0.0, 1.0],    # closer than range_min
                    [0.0, 6.0, 1.0],    # farther than range_max
                    [0.0, -3.0, 0.96],  # in the slab -> 3.0 at -pi/2
                    [np.nan, 0.0, 1.0]], np.float32)
    (scan,) = virtualize(pts, plane, params)
    finite = np.flatnonzero(np.isfinite(scan.ranges))
    assert len(finite) == 2
    np.testing.assert_allclose(scan.ranges[finite], [3.0, 2.0], rtol=1e-6)
    np.testing.assert_allclose(scan.angles()[finite], [-math.pi / 2, 0.0], atol=0.011)
    assert scan.header.frame_id == "virtual_scan_0"


def test_oblique_plane_sees_the_floor_at_the_analytic_distance():
    # A plane pitched down by 0.3 rad through a point 0.5 m up meets the floor 0.5 / tan(0.3) ahead.
    info = camera_info()
    depth = render([floor()], CAM, info)
    (plane,) = oblique_planes(Vector3(0.0, 0.0, 0.5), pitches=(0.3,))
    (scan,) = virtualize(depth_to_cloud(depth, info), [plane], VP, cloud_to_base=optical_pose(CAM))
    ahead = np.abs(scan.angles()) < 0.01
    expected = 0.5 / math.sin(0.3)  # in-plane distance to the floor line
    assert np.all(np.abs(scan.ranges[ahead] - expected) < 0.1)
    assert len(horizontal_planes(n=3)) == 3


def test_merge_of_rotated_scans_matches_analytic_wall():
    # Two 90-degree scanners yawed +-0.6 rad, 0.2 m apart, each seeing a wall at x = 2 in base_link.
    mounts = [Transform.from_xyz_rpy(0.1, 0.1, 0.3, 0.0, 0.0, 0.6),
              Transform.from_xyz_rpy(0.1, -0.1, 0.3, 0.0, 0.0, -0.6)]
    scans = []
    for i, m in enumerate(mounts):
        ang = -0.8 + 0.002 * np.arange(801)
        world = m.rotation.yaw + ang
        r = (2.0 - m.translation.x) / np.cos(world)  # distance along the beam to x = 2
        r[np.abs(world) > 1.2] = np.inf
        scans.append(LaserScan(Header(5.0 + 0.01 * i, f"laser{i}"), -0.8, 0.8, 0.002, 0.0, 0.0, 0.05, 20.0,
                               r.astype(np.float32)))
    merged, cloud = merge_scans(zip(scans, mounts), MP)
    a = merged.angles()
    r = merged.ranges
    assert merged.header.stamp == pytest.approx(5.01)
    inc = MP.angle_increment
    tol = 2.0 * np.sin(np.abs(a) + inc) / np.cos(np.abs(a) + inc) ** 2 * (inc / 2 + 0.002) + 1e-3
    assert np.all(np.abs(r - 2.0 / np.cos(a)) <= tol)
    np.testing.assert_allclose(cloud.points[:, 0], 2.0, atol=1e-4)
    np.testing.assert_allclose(cloud.points[:, 2], 0.3, atol=1e-5)


def test_merger_range_and_angle_limits():
    scan = LaserScan(Header(0.0, "l"), -1.0, 1.0, 0.5, 0.0, 0.0, 0.0, 100.0,
                     np.array([0.2, 30.0, 3.0, np.inf, np.nan], np.float32))
    assert len(scan_to_points(scan)) == 3  # inf and NaN are no return
    p = MergerParams(angle_min=-0.75, angle_max=0.75, angle_increment=0.25, range_min=0.45, range_max=25.0)
    merged, _ = merge_scans([(scan, Transform())], p)
    assert len(merged.ranges) == 6
    finite = np.flatnonzero(np.isfinite(merged.ranges))
    assert finite.tolist() == [3]  # only the 3 m return at angle 0 survives (0.2 < range_min, 30 > max)
    assert merged.ranges[3] == pytest.approx(3.0)


def _scan(stamp: float, rng: float, frame: str) -> LaserScan:
    return LaserScan(Header(stamp, frame), -0.5, 0.5, 0.01, 0.0, 0.0, 0.1, 10.0,
                     np.full(101, rng, np.float32))


def test_scan_merger_merges_scans_with_different_stamps_within_max_age():
    p = MergerParams(laserscan_topics="left right", max_scan_age=0.5, angle_min=-2.0, angle_max=2.0,
                     angle_increment=0.02)
    m = ScanMerger(p)
    assert m.topics == ("left", "right")
    assert m.merge() is None
    left, right = Transform.from_xyz_rpy(0, 0, 0, 0, 0, 1.0), Transform.from_xyz_rpy(0, 0, 0, 0, 0, -1.0)
    m.update("left", _scan(10.0, 2.0, "l"), left)
    assert m.ready(10.0)  # the only live input is new
    m.update("right", _scan(10.3, 3.0, "r"), right)
    assert m.ready(10.3)
    merged, _ = m.merge(now=10.3)
    a = merged.angles()
    assert merged.header.stamp == pytest.approx(10.3)
    assert np.all(merged.ranges[(a > 0.6) & (a < 1.4)] == pytest.approx(2.0))
    assert np.all(merged.ranges[(a < -0.6) & (a > -1.4)] == pytest.approx(3.0))
    assert not m.ready(10.3)  # nothing new since the merge
    m.update("right", _scan(10.9, 3.0, "r"), right)
    assert m.ready(10.9)  # left is stale (0.9 s old): it no longer blocks...
    merged, _ = m.merge(now=10.9)
    assert np.all(np.isposinf(merged.ranges[(a > 0.6) & (a < 1.4)]))  # ...and is left out
    assert np.all(merged.ranges[(a < -0.6) & (a > -1.4)] == pytest.approx(3.0))
    assert m.merge(now=20.0) is None
    with pytest.raises(KeyError):
        m.update("other", _scan(1.0, 1.0, "x"), left)


def test_params_load_with_ros_names():
    ros = {"destination_frame": "base_link", "cloud_destination_topic": "/merged_cloud",
           "scan_destination_topic": "/scan", "laserscan_topics": ["/scan1", "scan2"],
           "angle_min": -1.0, "angle_max": 1.0}
    mp = load_params(MergerParams, ros, source="m.yaml")
    assert mp.topics() == ("scan1", "scan2")
    with pytest.raises(ConfigError, match="angle_max"):
        load_params(MergerParams, {"angle_min": 1.0, "angle_max": 0.5}, source="m.yaml")
    vp = load_params(VirtualizerParams, {"base_frame": "base_link", "virtual_planes": [[0, 0, 0.3, 0, 0, 0]],
                                         "virtual_laser_scan": ["scan1"]}, source="v.yaml")
    assert vp.planes()[0].translation.z == pytest.approx(0.3)
    assert vp.frame_ids(1) == ["scan1"]
    with pytest.raises(ConfigError, match="6 numbers"):
        load_params(VirtualizerParams, {"virtual_planes": [[0, 0, 0.3]]}, source="v.yaml")
