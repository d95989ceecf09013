"""depth image -> LaserScan, checked against analytic ranges of rendered scenes."""

from __future__ import annotations

import math

import numpy as np
import pytest
from depth_scene import Box, camera_info, floor, render, wall_tolerance, wall_x
from hypothesis import given, settings
from hypothesis import strategies as st

from common.config import ConfigError, load_params
from common.geometry import Transform
from common.messages import DepthImage, Header
from robot_side.depth.depth_to_scan import DepthToScan, DepthToScanParams, depth_to_scan

LEVEL_CAM = Transform.from_xyz_rpy(0.0, 0.0, 0.5, 0.0, 0.0, 0.0)


def _image(depth: np.ndarray, stamp: float = 1.0) -> DepthImage:
    return DepthImage(Header(stamp, "camera_depth_optical_frame"), depth)


@pytest.mark.parametrize(("width", "fx", "cx"), [(320, 262.5, None), (640, 525.0, None), (160, 100.0, 70.0)])
def test_flat_wall_gives_planar_ranges_over_the_whole_fov(width, fx, cx):
    info = camera_info(width, width * 3 // 4, fx, cx=cx)
    dist = 2.0
    depth = render([wall_x(dist), floor()], LEVEL_CAM, info)
    scan = depth_to_scan(_image(depth), info)
    a = scan.angles()
    assert len(scan.ranges) == info.width
    assert scan.angle_max == pytest.approx(math.atan(info.cx / fx))
    assert scan.angle_min == pytest.approx(-math.atan((info.width - 1 - info.cx) / fx))
    assert a[-1] == pytest.approx(scan.angle_max)
    assert np.all(np.isfinite(scan.ranges))
    err = np.abs(scan.ranges - dist / np.cos(a))
    assert np.all(err <= wall_tolerance(dist, a, fx))
    assert err[0] < 1e-5
    assert err[-1] < 1e-5
    assert scan.header.frame_id == "camera_depth_frame"
    assert scan.header.stamp == 1.0


def test_left_of_image_is_positive_angle():
    info = camera_info()
    # A box on the robot's left (y > 0) at 1.2 m, wall at 3 m.
    box = Box((1.2, 0.1, 0.0), (1.5, 1.0, 1.0))
    scan = depth_to_scan(_image(render([box, wall_x(3.0), floor()], LEVEL_CAM, info)), info)
    a = scan.angles()
    near = scan.ranges < 2.0
    assert near.any()
    assert np.all(a[near] > 0.0)
    right = a < -0.01
    err = np.abs(scan.ranges[right] - 3.0 / np.cos(a[right]))
    assert np.all(err <= wall_tolerance(3.0, a[right], info.fx))


def test_low_box_under_the_band_is_missed():
    """The tutorial's point: the single image row at sensor height misses low obstacles."""
    info = camera_info()
    box = Box((1.5, -0.2, 0.0), (1.8, 0.2, 0.35))  # under the sensor (z = 0.5)
    depth = render([box, wall_x(4.0), floor()], LEVEL_CAM, info)
    assert np.any(np.abs(depth - 1.5) < 1e-3)  # the box is in the image...
    scan = depth_to_scan(_image(depth), info, DepthToScanParams(scan_height=5))
    a = scan.angles()
    # ...but not in the scan
    assert np.all(np.abs(scan.ranges - 4.0 / np.cos(a)) <= wall_tolerance(4.0, a, info.fx))


def test_tall_band_sees_what_the_centre_row_misses():
    info = camera_info()
    box = Box((1.5, -0.2, 0.0), (1.8, 0.2, 0.45))  # top 5 cm below the optical axis
    depth = render([box, wall_x(4.0), floor()], LEVEL_CAM, info)
    thin = depth_to_scan(_image(depth), info, DepthToScanParams(scan_height=1))
    thick = depth_to_scan(_image(depth), info, DepthToScanParams(scan_height=60))
    assert thin.ranges.min() > 3.9
    assert thick.ranges.min() == pytest.approx(1.5, abs=2e-3)


def test_range_limits_are_honoured_per_ray():
    info = camera_info()
    dist = 1.0
    depth = render([wall_x(dist)], LEVEL_CAM, info)
    rmax = dist / math.cos(0.3)
    scan = depth_to_scan(_image(depth), info, DepthToScanParams(range_min=0.2, range_max=rmax))
    a = scan.angles()
    inside = np.abs(a) < 0.3 - 0.005
    outside = np.abs(a) > 0.3 + 0.005
    assert np.all(np.isfinite(scan.ranges[inside]))
    assert np.all(np.isposinf(scan.ranges[outside]))
    too_close = depth_to_scan(_image(depth), info, DepthToScanParams(range_min=1.5, range_max=10.0))
    assert np.all(np.isposinf(too_close.ranges))


def test_return_closer_than_range_min_does_not_hide_a_valid_one():
    info = camera_info()
    depth = render([wall_x(2.0)], LEVEL_CAM, info)
    depth[info.height // 2 - 1] = 0.1  # a row of too-close junk inside a 3-row band
    scan = depth_to_scan(_image(depth), info, DepthToScanParams(scan_height=3, range_min=0.45))
    a = scan.angles()
    assert np.all(np.abs(scan.ranges - 2.0 / np.cos(a)) <= wall_tolerance(2.0, a, info.fx))


def test_invalid_pixels_are_no_return_never_obstacles():
    info = camera_info()
    depth = render([wall_x(2.5)], LEVEL_CAM, info)
    depth[:, :40] = 0.0
    depth[:, 40:80] = np.nan
    depth[:, 80:100] = np.inf
    depth[:, 100:110] = -1.0
    scan = depth_to_scan(_image(depth), info, DepthToScanParams(scan_height=9, range_min=0.0))
    a = scan.angles()
    cols_bad = a > math.atan((info.cx - 110) / info.fx) + 0.01  # rays of columns 0..109
    assert np.all(np.isposinf(scan.ranges[cols_bad]))
    good = a < math.atan((info.cx - 110) / info.fx) - 0.01
    assert np.all(np.abs(scan.ranges[good] - 2.5 / np.cos(a[good])) <= wall_tolerance(2.5, a[good], info.fx))


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**31 - 1), st.floats(0.0, 0.95), st.integers(1, 30))
def test_random_holes_never_shorten_a_range(seed, hole_fraction, scan_height):
    info = camera_info(64, 48, 52.5)
    dist = 1.7
    depth = render([wall_x(dist)], LEVEL_CAM, info)
    rng = np.random.default_rng(seed)
    holes = rng.random(depth.shape) < hole_fraction
    depth[holes] = rng.choice(np.array([0.0, np.nan], np.float32), size=int(holes.sum()))
    scan = depth_to_scan(_image(depth), info, DepthToScanParams(scan_height=scan_height, range_min=0.0))
    truth = dist / np.cos(scan.angles())
    finite = np.isfinite(scan.ranges)
    tol = wall_tolerance(dist, scan.angles(), info.fx)
    assert np.all(np.abs(scan.ranges[finite] - truth[finite]) <= tol[finite])
    assert np.all(np.isposinf(scan.ranges[~finite]))


def test_all_invalid_image_gives_all_no_return():
    info = camera_info()
    scan = depth_to_scan(_image(np.zeros((info.height, info.width), np.float32)), info)
    assert np.all(np.isposinf(scan.ranges))


def test_lookup_tables_follow_camera_info_changes():
    conv = DepthToScan(DepthToScanParams(range_min=0.0))
    qvga, qqvga = camera_info(320, 240, 262.5), camera_info(160, 120, 131.25)
    for info in (qvga, qqvga, qvga):
        scan = conv.convert(_image(render([wall_x(1.0)], LEVEL_CAM, info)), info)
        assert len(scan.ranges) == info.width
        a = scan.angles()
        assert np.all(np.abs(scan.ranges - 1.0 / np.cos(a)) <= wall_tolerance(1.0, a, info.fx))
    with pytest.raises(ValueError, match="depth image"):
        conv.convert(_image(np.zeros((10, 10), np.float32)), qvga)


def test_params_load_with_ros_names_and_reject_bad_values():
    p = load_params(DepthToScanParams, {"scan_height": 10, "range_min": 0.3, "range_max": 6.0,
                                        "output_frame_id": "kinect_depth_frame"}, source="d.yaml")
    assert p == DepthToScanParams(10, 0.033, 0.3, 6.0, "kinect_depth_frame")
    with pytest.raises(ConfigError, match="scan_height"):
        load_params(DepthToScanParams, {"scan_height": 0}, source="d.yaml")
    with pytest.raises(ConfigError, match="range_max"):
        load_params(DepthToScanParams, {"range_min": 5.0, "range_max": 1.0}, source="d.yaml")
