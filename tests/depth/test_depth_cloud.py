"""depth image -> point cloud in the optical frame."""

from __future__ import annotations

import numpy as np
import pytest
from depth_scene import Box, camera_info, floor, optical_pose, render, wall_x

from common.geometry import Transform
from common.messages import DepthImage, Header
from robot_side.depth.cloud import CloudParams, DepthToCloud, depth_to_cloud

CAM = Transform.from_xyz_rpy(0.1, 0.0, 0.5, 0.0, 0.0, 0.0)


def test_cloud_points_lie_on_the_rendered_surfaces():
    info = camera_info()
    box = Box((1.0, -0.3, 0.0), (1.4, 0.2, 0.3))
    depth = render([wall_x(3.0), floor(), box], CAM, info)
    pts = depth_to_cloud(depth, info)
    assert pts.dtype == np.float32
    assert pts.shape == (np.count_nonzero(depth), 3)
    base = optical_pose(CAM).apply(pts.astype(np.float64))
    on_wall = np.abs(base[:, 0] - 3.0) < 1e-4
    on_floor = np.abs(base[:, 2]) < 1e-4
    lo, hi = np.array(box.lo), np.array(box.hi)
    on_box = np.all((base >= lo - 1e-4) & (base <= hi + 1e-4), axis=1)
    assert on_wall.any()
    assert on_floor.any()
    assert on_box.any()
    assert np.all(on_wall | on_floor | on_box)


def test_cloud_reprojects_to_its_pixels():
    info = camera_info(64, 48, 52.5, cx=30.0, cy=20.0)
    depth = render([wall_x(2.0), floor()], CAM, info)
    pts = depth_to_cloud(depth, info).astype(np.float64)
    u = pts[:, 0] / pts[:, 2] * info.fx + info.cx
    v = pts[:, 1] / pts[:, 2] * info.fy + info.cy
    vv, uu = np.nonzero(depth)  # row-major, same order as the cloud
    np.testing.assert_allclose(u, uu, atol=1e-3)
    np.testing.assert_allclose(v, vv, atol=1e-3)
    np.testing.assert_allclose(pts[:, 2], depth[vv, uu], rtol=1e-6)


def test_invalid_pixels_are_dropped():
    info = camera_info(80, 60, 65.0)
    depth = render([wall_x(2.0)], CAM, info)
    depth[0, :] = 0.0
    depth[1, :] = np.nan
    depth[2, :] = np.inf
    depth[3, :] = -2.0
    pts = depth_to_cloud(depth, info)
    assert len(pts) == (info.height - 4) * info.width
    assert np.all(np.isfinite(pts))
    assert np.all(pts[:, 2] > 0.0)


def test_decimation_keeps_every_nth_pixel():
    info = camera_info(80, 60, 65.0)
    depth = render([wall_x(2.0)], CAM, info)
    full = depth_to_cloud(depth, info)
    dec = depth_to_cloud(depth, info, decimation=4)
    assert len(dec) == len(range(0, 60, 4)) * len(range(0, 80, 4))
    # Every decimated point is one of the full-resolution points (pixel (4i, 4j)).
    full_grid = full.reshape(60, 80, 3)
    np.testing.assert_array_equal(dec.reshape(15, 20, 3), full_grid[::4, ::4])


def test_range_max_and_message_wrapping():
    info = camera_info(80, 60, 65.0)
    depth = render([wall_x(2.0), Box((1.0, -0.2, 0.3), (1.2, 0.2, 0.7))], CAM, info)
    conv = DepthToCloud(CloudParams(range_max=1.5))
    msg = conv.convert(DepthImage(Header(4.5, "cam_opt"), depth), info)
    assert msg.header == Header(4.5, "cam_opt")
    assert len(msg.points) > 0
    assert msg.points[:, 2].max() <= 1.5
    with pytest.raises(ValueError, match="depth image"):
        conv.points(depth[:10], info)
