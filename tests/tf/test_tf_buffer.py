"""TFBuffer: interpolation, composition, static edges, errors, waiting — against analytic transforms."""

from __future__ import annotations

import math
import threading
import time

import numpy as np
import pytest
from tf_analytic import hom, rot_x, rot_y, rot_z

from common.clock import SimClock
from common.geometry import Pose2D, Quaternion, Transform, Vector3
from common.messages import Header, TransformStamped
from common.tf import parse_static_args
from common.tf_buffer import ConnectivityError, ExtrapolationError, TFBuffer, UnknownFrameError

R, W = 2.0, 0.5  # circle radius (m), angular speed (rad/s)
CAM = "0.1 0 0.35 0 pi/2 pi/2 base_link camera_link 100"  # the p3at static transform


def ts(parent: str, child: str, stamp: float, tr: Transform) -> TransformStamped:
    return TransformStamped(Header(stamp, parent), child, tr)


def circle_pose(t: float) -> Pose2D:
    """Robot on a circle of radius R centred at the origin, heading along the tangent."""
    a = W * t
    return Pose2D(R * math.cos(a), R * math.sin(a), a + math.pi / 2)


def circle_matrix(t: float) -> np.ndarray:
    p = circle_pose(t)
    return hom(rot_z(p.theta), [p.x, p.y, 0.0])


MAP_ODOM = Pose2D(1.0, -0.5, 0.3)
M_MAP_ODOM = hom(rot_z(0.3), [1.0, -0.5, 0.0])
M_BASE_CAM = hom(rot_z(0.0) @ rot_y(math.pi / 2) @ rot_x(math.pi / 2), [0.1, 0.0, 0.35])


class FakeClock:
    simulated = False

    def __init__(self, t: float = 0.0) -> None:
        self.t = t

    def now(self) -> float:
        return self.t


def robot_buffer(t_end: float = 4.0, dt: float = 0.1, clock=None) -> TFBuffer:
    buf = TFBuffer(cache_time=10.0, clock=clock)
    buf.set_transform(parse_static_args(CAM)[0], authority="static_tf", static=True)
    for k in range(int(round(t_end / dt)) + 1):
        t = k * dt
        buf.set_transform(ts("map", "odom", t, MAP_ODOM.to_transform()), authority="amcl")
        buf.set_transform(ts("odom", "base_link", t, circle_pose(t).to_transform()), authority="odometry")
    return buf


def test_interpolation_is_exact_for_straight_line_while_spinning():
    buf = TFBuffer()
    v, w = 0.7, 1.3  # linear translation + constant spin: lerp and slerp are both exact
    for k in range(11):
        t = 0.2 * k
        buf.set_transform(ts("odom", "base_link", t, Pose2D(v * t, 0.5 * v * t, w * t).to_transform()))
    for t in (0.05, 0.31, 0.999, 1.5, 1.77):
        p = buf.lookup_pose2d("odom", "base_link", t)
        assert p.x == pytest.approx(v * t, abs=1e-9)
        assert p.y == pytest.approx(0.5 * v * t, abs=1e-9)
        assert math.cos(p.theta - w * t) == pytest.approx(1.0, abs=1e-12)


def test_circle_lookup_at_intermediate_times_matches_analytic_pose():
    buf, dt = robot_buffer(dt=0.1), 0.1
    sagitta = R * (1 - math.cos(W * dt / 2))  # linear interpolation cuts the arc by at most this
    for t in np.linspace(0.013, 3.97, 37):
        p, exact = buf.lookup_pose2d("odom", "base_link", float(t)), circle_pose(float(t))
        assert p.distance(exact) <= sagitta + 1e-9
        assert math.cos(p.theta - exact.theta) == pytest.approx(1.0, abs=1e-12)  # slerp about z: exact yaw


def test_chain_map_to_camera_matches_analytic_camera_pose():
    buf = robot_buffer()
    for t in (0.1, 1.2, 2.5, 4.0):  # sample times: every edge is exact there
        want = M_MAP_ODOM @ circle_matrix(t) @ M_BASE_CAM
        got = buf.lookup("map", "camera_link", t)
        assert (got.header.frame_id, got.child_frame_id, got.header.stamp) == ("map", "camera_link", t)
        np.testing.assert_allclose(got.transform.as_matrix(), want, atol=1e-9)
        inv = buf.lookup("camera_link", "map", t)  # inverse direction
        np.testing.assert_allclose(inv.transform.as_matrix(), np.linalg.inv(want), atol=1e-9)
        pts = np.array([[0.0, 0.0, 1.0], [0.3, -0.2, 2.0]])  # along the camera's optical axis
        want_pts = (want @ np.c_[pts, np.ones(2)].T).T[:, :3]
        np.testing.assert_allclose(buf.transform_points("map", "camera_link", pts, t), want_pts, atol=1e-9)
        p2 = buf.lookup_pose2d("map", "base_link", t)
        np.testing.assert_allclose(p2.as_array()[:2], (M_MAP_ODOM @ circle_matrix(t))[:2, 3], atol=1e-9)


def test_lookup_between_sibling_branches_goes_through_common_ancestor():
    buf = robot_buffer()
    buf.set_transform(ts("base_link", "laser", 0.0, Transform.from_xyz_rpy(-0.2, 0.1, 0.3, 0, 0, math.pi)),
                      static=True)
    m_base_laser = hom(rot_z(math.pi), [-0.2, 0.1, 0.3])
    got = buf.lookup("camera_link", "laser", 2.0).transform.as_matrix()
    np.testing.assert_allclose(got, np.linalg.inv(M_BASE_CAM) @ m_base_laser, atol=1e-9)
    pts2 = np.array([[1.0, 0.0], [0.0, 2.0]])  # 2D points: taken at z = 0
    want = (np.linalg.inv(M_MAP_ODOM @ circle_matrix(2.0)) @ M_MAP_ODOM @ np.c_[pts2, [0, 0], [1, 1]].T).T
    np.testing.assert_allclose(buf.transform_points("base_link", "odom", pts2, 2.0), want[:, :2], atol=1e-9)


def test_time_zero_uses_latest_common_time():
    buf = TFBuffer()
    for t in (0.0, 0.5, 1.0):
        buf.set_transform(ts("map", "odom", t, Pose2D(t, 0, 0).to_transform()))
    for t in (0.0, 1.0, 2.0):
        buf.set_transform(ts("odom", "base_link", t, Pose2D(0, t, 0).to_transform()))
    got = buf.lookup("map", "base_link")
    assert got.header.stamp == 1.0
    assert got.transform.translation == Vector3(1.0, 1.0, 0.0)
    assert buf.lookup("odom", "base_link").header.stamp == 2.0


def test_static_transform_never_expires_while_dynamic_history_is_pruned():
    clock = FakeClock(0.0)
    buf = TFBuffer(cache_time=2.0, clock=clock)
    buf.set_transform(parse_static_args(CAM)[0], static=True)
    for k in range(101):  # 10 s of odometry at 10 Hz, cache holds 2 s
        buf.set_transform(ts("odom", "base_link", k * 0.1, circle_pose(k * 0.1).to_transform()))
    clock.t = 1e6
    for t in (0.0, -5.0, 1e5):
        got = buf.lookup("base_link", "camera_link", t).transform.as_matrix()
        np.testing.assert_allclose(got, M_BASE_CAM, atol=1e-12)
    np.testing.assert_allclose(buf.lookup("odom", "camera_link", 9.5).transform.as_matrix(),
                               circle_matrix(9.5) @ M_BASE_CAM, atol=1e-3)
    with pytest.raises(ExtrapolationError, match="past"):
        buf.lookup("odom", "camera_link", 5.0)


def test_unknown_frame_error_names_the_frame():
    buf = robot_buffer()
    with pytest.raises(UnknownFrameError, match='"nowhere"') as e:
        buf.lookup("map", "nowhere")
    assert isinstance(e.value, LookupError)
    assert not buf.can_transform("nowhere", "map")


def test_not_connected_error_names_both_roots():
    buf = robot_buffer()
    buf.set_transform(ts("world", "gps", 0.0, Transform()), static=True)
    buf.set_transform(ts("gps", "antenna", 0.0, Transform()), static=True)
    with pytest.raises(ConnectivityError) as e:
        buf.lookup("camera_link", "antenna")
    assert '"map"' in str(e.value)
    assert '"world"' in str(e.value)
    assert isinstance(e.value, LookupError)


def test_extrapolation_errors_say_direction_amount_and_edge():
    buf = robot_buffer(t_end=4.0)
    with pytest.raises(ExtrapolationError, match=r"0\.5000 s into the future on edge odom -> base_link"):
        buf.lookup("camera_link", "odom", 4.5)
    buf2 = TFBuffer(cache_time=10.0)
    for t in (3.0, 4.0):
        buf2.set_transform(ts("odom", "base_link", t, Transform()))
    with pytest.raises(ExtrapolationError, match=r"0\.2500 s into the past on edge odom -> base_link"):
        buf2.lookup("odom", "base_link", 2.75)
    assert buf2.can_transform("odom", "base_link", 3.5)
    tolerant = TFBuffer(tolerance=0.3)
    tolerant.set_transform(ts("odom", "base_link", 4.0, Transform()))
    assert tolerant.can_transform("odom", "base_link", 4.25)
    assert not tolerant.can_transform("odom", "base_link", 4.35)


def test_leading_slash_is_stripped_and_same_frame_is_identity():
    buf = TFBuffer()
    buf.set_transform(ts("/odom", "/base_link", 1.0, Pose2D(1, 2, 0).to_transform()))
    assert buf.frames() == ["base_link", "odom"]
    assert buf.lookup("/odom", "base_link").transform.translation == Vector3(1.0, 2.0, 0.0)
    assert buf.lookup("odom", "/odom").transform == Transform()


def test_malformed_transforms_are_rejected():
    buf = TFBuffer()
    with pytest.raises(ValueError, match="itself"):
        buf.set_transform(ts("a", "a", 0.0, Transform()))
    with pytest.raises(ValueError, match="non-finite"):
        buf.set_transform(ts("a", "b", 0.0, Transform(Vector3(math.nan, 0, 0))))
    with pytest.raises(ValueError, match="zero-length"):
        buf.set_transform(ts("a", "b", 0.0, Transform(rotation=Quaternion(0, 0, 0, 0))))
    assert buf.frames() == []


def test_edge_metadata_reports_publisher_rate_age_and_static():
    clock = FakeClock(4.25)
    buf = robot_buffer(t_end=4.0, dt=0.1, clock=clock)
    info = {(e.parent, e.child): e for e in buf.edges()}
    assert set(info) == {("map", "odom"), ("odom", "base_link"), ("base_link", "camera_link")}
    ob = info[("odom", "base_link")]
    assert (ob.publisher, ob.static, ob.received) == ("odometry", False, 41)
    assert ob.rate_hz == pytest.approx(10.0)
    assert ob.age == pytest.approx(0.25)
    assert (ob.latest_stamp, ob.oldest_stamp) == (4.0, 0.0)
    cam = info[("base_link", "camera_link")]
    assert (cam.publisher, cam.static, cam.rate_hz) == ("static_tf", True, 0.0)


class SignallingClock(FakeClock):
    """Sets ``waiting`` on the second now() call: lookup has failed once and is about to wait."""

    def __init__(self) -> None:
        super().__init__(0.0)
        self.calls, self.waiting = 0, threading.Event()

    def now(self) -> float:
        self.calls += 1
        if self.calls == 2:
            self.waiting.set()
        return time.monotonic()


def test_lookup_waits_for_transform_that_arrives_during_the_timeout():
    clock = SignallingClock()
    buf = TFBuffer(clock=clock)
    result: dict = {}

    def waiter():
        t0 = time.monotonic()
        try:
            result["ts"] = buf.lookup("map", "base_link", 0.0, timeout=20.0)
        except Exception as e:  # noqa: BLE001 - reported below
            result["err"] = e
        result["elapsed"] = time.monotonic() - t0

    th = threading.Thread(target=waiter)
    th.start()
    assert clock.waiting.wait(10.0), "lookup never started waiting"
    buf.set_transform(ts("map", "base_link", 5.0, Pose2D(3, 0, 0).to_transform()))
    th.join(10.0)
    assert "err" not in result, result.get("err")
    assert result["ts"].transform.translation.x == 3.0
    assert result["elapsed"] < 10.0


def test_lookup_times_out_with_the_last_error():
    buf = TFBuffer()
    buf.set_transform(ts("map", "odom", 1.0, Transform()))
    t0 = time.monotonic()
    with pytest.raises(ExtrapolationError, match="after waiting"):
        buf.lookup("map", "odom", 2.0, timeout=0.3)
    assert time.monotonic() - t0 >= 0.29
    with pytest.raises(UnknownFrameError):
        buf.lookup("map", "base_link", 0.0, timeout=0.05)


class CountingSimClock(SimClock):
    def __init__(self) -> None:
        super().__init__()
        self.calls, self.waiting = 0, threading.Event()

    def now(self) -> float:
        self.calls += 1
        if self.calls == 2:
            self.waiting.set()
        return super().now()


def test_lookup_timeout_follows_the_simulated_clock():
    clock = CountingSimClock()
    clock.update(100.0)
    buf = TFBuffer(clock=clock)
    result: dict = {}

    def waiter():
        try:
            buf.lookup("map", "odom", 0.0, timeout=1.0)  # 1 s of *simulated* time
        except UnknownFrameError as e:
            result["err"] = e

    th = threading.Thread(target=waiter)
    th.start()
    assert clock.waiting.wait(10.0)
    assert "err" not in result  # the sim clock has not moved: still waiting
    clock.update(101.5)
    th.join(10.0)
    assert not th.is_alive()
    assert "err" in result
