import math

import numpy as np
import pytest
from sim_helpers import wall_world

from common.geometry import OPTICAL_FROM_LINK, Pose2D
from robot_side.sim.depth_camera import DEPTH_MODES, DepthCamera, DepthCameraParams
from robot_side.sim.world import World

RES = 0.02
Z = 0.35


def _cam(world, **kw):
    base = dict(x=0.0, y=0.0, z=Z, yaw=0.0, noise_std=0.0, noise_z2=0.0, range_min=0.1, range_max=20.0,
                depth_mode=8)
    return DepthCamera(world, DepthCameraParams(**{**base, **kw}))


def test_intrinsics_follow_the_fov_and_mode():
    for mode, (w, h) in DEPTH_MODES.items():
        cam = _cam(wall_world(3.0), depth_mode=mode)
        info = cam.camera_info(1.5)
        assert (info.width, info.height) == (w, h)
        assert math.isclose(2 * math.atan((w / 2) / info.fx), math.radians(57))
        assert math.isclose(2 * math.atan((h / 2) / info.fy), math.radians(43))
        assert (info.cx, info.cy) == ((w - 1) / 2, (h - 1) / 2)
        img = cam.frame(Pose2D()).depth
        assert img.shape == (h, w)
        assert img.dtype == np.float32


def test_wall_gives_depth_d_above_the_floor_and_floor_below():
    d = 2.5
    cam = _cam(wall_world(d, height=3.0), depth_mode=5)
    img = cam.frame(Pose2D()).depth
    v = np.arange(cam.height)
    t = (v - cam.cy) / cam.fy
    with np.errstate(divide="ignore"):
        floor = np.where(t > 0, Z / t, np.inf)
    sees_wall = floor > d + RES  # rows whose ray meets the wall before the floor
    assert sees_wall.sum() > cam.height / 2
    np.testing.assert_allclose(img[sees_wall], d, atol=RES)
    below = floor < d - RES
    assert below.any()
    expected = np.broadcast_to(floor[below][:, None], img[below].shape)
    np.testing.assert_allclose(img[below], expected, rtol=1e-5)


def test_tall_box_top_edge_row_matches_the_intrinsics():
    d1, hb = 1.5, 0.7  # box face at 1.5 m, its top 0.35 m above the camera; wall behind at 4 m
    box = {"center": [d1 + 0.25, 0.0], "size": [0.5, 6.0], "height": hb}
    cam = _cam(wall_world(4.0, extra_boxes=[box]), depth_mode=2)
    col = cam.frame(Pose2D()).depth[:, cam.width // 2]
    first_box_row = math.floor(cam.cy + cam.fy * (Z - hb) / d1) + 1
    rows_on_box = np.flatnonzero(np.abs(col - d1) < RES)
    assert abs(rows_on_box.min() - first_box_row) <= 1
    above = col[: first_box_row - 1]
    np.testing.assert_allclose(above, 4.0, atol=RES)  # rows above the box's top see past it


def test_low_box_top_is_seen_from_above_and_rows_above_see_past_it():
    near, far, hb = 1.0, 1.6, 0.15  # box under the camera height: its top face is visible
    box = {"center": [(near + far) / 2, 0.0], "size": [far - near, 6.0], "height": hb}
    cam = _cam(wall_world(4.0, extra_boxes=[box]), depth_mode=2)
    col = cam.frame(Pose2D()).depth[:, cam.width // 2]
    v = np.arange(cam.height)
    t = (v - cam.cy) / cam.fy
    top_rows = (t > (Z - hb) / far + 2 / cam.fy) & (t < (Z - hb) / near - 2 / cam.fy)
    assert top_rows.sum() > 10
    assert np.all((col[top_rows] >= near - RES) & (col[top_rows] <= far + RES))
    past = (t > 0) & (t < (Z - hb) / far - 2 / cam.fy)  # rays passing over the box hit the floor beyond
    assert past.any()
    np.testing.assert_allclose(col[past], np.minimum(Z / t[past], 4.0), atol=RES)  # the floor or the wall


def test_range_limits_invalidate_to_zero():
    cam = _cam(wall_world(3.0), range_min=0.5, range_max=2.0, depth_mode=8)
    img = cam.frame(Pose2D()).depth
    assert np.all((img == 0) | ((img >= 0.5) & (img <= 2.0)))
    assert np.all(img[: cam.height // 2] == 0)  # the wall at 3 m is beyond range_max
    near = _cam(wall_world(0.3), range_min=0.5, depth_mode=8).frame(Pose2D()).depth
    assert np.all(near == 0)


def test_matches_a_brute_force_3d_march_in_a_random_world():
    rng = np.random.default_rng(3)
    boxes = [{"center": list(rng.uniform(0.8, 4, 1)) + list(rng.uniform(-2, 2, 1)),
              "size": list(rng.uniform(0.1, 0.6, 2)), "yaw": float(rng.uniform(0, 3)),
              "height": float(rng.uniform(0.1, 1.0))} for _ in range(15)]
    world = World.from_shapes({"bounds": [-1, -3, 5, 3], "resolution": RES, "boxes": boxes})
    cam = _cam(world, depth_mode=8, range_max=5.0)
    pose = Pose2D(0.0, 0.1, 0.05)
    img = cam.depth_exact(pose)
    s = cam.sensor_pose(pose)
    us, vs = np.meshgrid(np.arange(0, cam.width, 3), np.arange(0, cam.height, 3))
    us, vs = us.ravel(), vs.ravel()
    fwd = np.ones(len(us))
    left = -(us - cam.cx) / cam.fx
    down = (vs - cam.cy) / cam.fy
    step = 0.002
    depth = np.arange(step, 5.0, step)
    c, sn = math.cos(s.theta), math.sin(s.theta)
    xs = s.x + (c * fwd - sn * left)[:, None] * depth
    ys = s.y + (sn * fwd + c * left)[:, None] * depth
    zs = Z - down[:, None] * depth
    blocked = (world.height_at(xs, ys) > zs) | (zs <= 0)
    ref = np.where(blocked.any(1), depth[np.argmax(blocked, 1)], np.inf)
    got = img[vs, us]
    with np.errstate(invalid="ignore"):
        agree = (np.isinf(ref) & np.isinf(got)) | (np.abs(got - ref) <= RES + step)
    assert agree.mean() > 0.98  # box tops are reported at their cell entry (<= 1 cell deep)


def test_noise_grows_with_depth_squared():
    cam = _cam(wall_world(3.0, height=3.0), depth_mode=5, noise_z2=0.002, seed=4)
    exact = cam.depth_exact(Pose2D())
    wall = np.abs(exact - 3.0) < RES
    err = np.concatenate([(cam.frame(Pose2D()).depth - exact)[wall] for _ in range(5)])
    assert err.std() == pytest.approx(0.002 * 9.0, rel=0.1)


def test_optical_frame_axes():
    r = OPTICAL_FROM_LINK.rotation.as_matrix()
    np.testing.assert_allclose(r @ [0, 0, 1], [1, 0, 0], atol=1e-12)  # optical z = forward
    np.testing.assert_allclose(r @ [1, 0, 0], [0, -1, 0], atol=1e-12)  # optical x = right
    np.testing.assert_allclose(r @ [0, 1, 0], [0, 0, -1], atol=1e-12)  # optical y = down


def test_data_skip_lowers_the_publish_rate():
    assert DepthCameraParams(data_skip=1).publish_rate == pytest.approx(15.0)
