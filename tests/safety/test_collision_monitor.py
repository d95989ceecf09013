"""The collision monitor's verdicts (pure), and the monitor closing the loop around the simulator."""

from __future__ import annotations

import math

import numpy as np
import pytest

from common.config import ConfigError
from common.geometry import Pose2D, points_in_polygon
from common.messages import Twist
from robot_side.safety.collision_monitor import CollisionMonitor
from robot_side.safety.node import scan_points
from robot_side.safety.params import PolygonParams, load_monitor, padded
from robot_side.sim.base import P3AT_FOOTPRINT, BaseParams
from robot_side.sim.laser import LaserParams
from robot_side.sim.simulator import Simulator, SimulatorParams
from robot_side.sim.world import World

SQUARE = ((0.3, 0.25), (-0.3, 0.25), (-0.3, -0.25), (0.3, -0.25))


def wall(x: float, n: int = 50, half: float = 1.0) -> np.ndarray:
    """Points of a wall across the robot's path at distance x."""
    return np.column_stack([np.full(n, x), np.linspace(-half, half, n)])


def approach(t: float = 0.6, **kw) -> CollisionMonitor:
    return CollisionMonitor([("approach", PolygonParams(time_before_collision=t, **kw))], SQUARE)


def test_points_in_polygon_even_odd_rule():
    inside = points_in_polygon(np.array([0.0, 0.29, 0.31, 0.0]), np.array([0.0, 0.2, 0.0, 0.3]),
                               np.array(SQUARE))
    assert inside.tolist() == [True, True, False, False]


def test_approach_ignores_a_wall_beyond_the_horizon_and_scales_down_near_it():
    m = approach(0.6, simulation_time_step=0.01)
    far = m.check(wall(1.0), 0.5, 0.0)  # 0.7 m gap: 1.4 s away
    assert far.action == "none" and far.v == 0.5
    near = m.check(wall(0.45), 0.5, 0.0)  # 0.15 m gap: 0.3 s away -> about half speed
    assert near.action == "approach" and near.polygon == "approach"
    assert near.ratio == pytest.approx(0.15 / 0.5 / 0.6, abs=0.03)
    assert near.v == pytest.approx(0.5 * near.ratio)
    assert near.points >= 4 and "within" in near.reason


def test_approach_lets_the_robot_back_away_or_turn_from_a_touching_obstacle():
    m = approach()
    touching = wall(0.28, half=0.2)  # points already inside the front of the polygon
    assert m.check(touching, 0.3, 0.0).action == "stop"
    assert m.check(touching, -0.3, 0.0).action == "none"
    assert m.check(touching, 0.0, 0.5).action == "none"  # a pure rotation does not move toward them


def test_a_base_turning_behind_base_link_is_predicted_as_that_turn():
    """rotation_center_x: the polygon moves along the commanded arc about the turning centre. The verdict is
    the plain (about base_link) one for the same robot and points laid about the centre instead; and a post
    that a turn in place about base_link would not reach, a turn about a centre 0.12 m behind (the P3-AT on
    physics) sweeps into: the front corners swing wider."""
    rng = np.random.default_rng(4)
    cx = -0.12
    shift = np.array([cx, 0.0])
    for _ in range(40):
        pts = rng.uniform(-1.2, 1.2, (30, 2))
        v, w = rng.uniform(-0.5, 0.5), rng.uniform(-1.5, 1.5)
        about = CollisionMonitor([("approach", PolygonParams(time_before_collision=1.0))], SQUARE, center_x=cx)
        plain = CollisionMonitor([("approach", PolygonParams(time_before_collision=1.0))],
                                 np.array(SQUARE) - shift)
        a, b = about.check(pts, v, w), plain.check(pts - shift, v, w)
        assert (a.action, a.ratio, a.points) == (b.action, b.ratio, b.points)
    # a post 0.47 m to the left of base_link, beyond its corners' 0.39 m; 0.45 m from the centre behind, within
    # the front corners' 0.49 m about it: a left turn in place about the centre sweeps the front left corner in
    post = np.array([[-0.12, 0.45]] * 5)
    assert approach(2.0).check(post, 0.0, 1.0).action == "none"
    swept = CollisionMonitor([("approach", PolygonParams(time_before_collision=2.0))], SQUARE, center_x=cx)
    assert swept.check(post, 0.0, 1.0).action == "approach"


def test_approach_slows_a_rotation_that_would_sweep_the_footprint_into_a_post():
    post = np.array([[0.2, 0.3]] * 5)  # beside the front-left corner, inside the circle it sweeps
    v = approach(1.0).check(post, 0.0, 1.0)
    assert v.action in ("approach", "stop") and abs(v.w) < 1.0


def test_few_points_are_noise_below_min_points():
    m = CollisionMonitor([("stop", PolygonParams(action_type="stop", min_points=4))], SQUARE)
    assert m.check(np.array([[0.1, 0.0]] * 3), 0.4, 0.0).action == "none"
    v = m.check(np.array([[0.1, 0.0]] * 4), 0.4, 0.2)
    assert (v.action, v.v, v.w, v.points) == ("stop", 0.0, 0.0, 4)


def test_the_most_restrictive_polygon_wins():
    big = ((1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0))
    m = CollisionMonitor([("slow", PolygonParams(action_type="slowdown", points=big, slowdown_ratio=0.3)),
                          ("limit", PolygonParams(action_type="limit", points=big, linear_limit=0.2)),
                          ("stop", PolygonParams(action_type="stop", points=SQUARE))], SQUARE)
    pts = np.array([[0.8, 0.0]] * 5)
    v = m.check(pts, 0.5, 0.4)  # slowdown -> 0.15, 0.12; limit -> 0.2 (ratio 0.4): slowdown wins
    assert (v.action, v.polygon) == ("slowdown", "slow")
    assert (v.v, v.w) == pytest.approx((0.15, 0.12))
    v = m.check(np.vstack([pts, [[0.0, 0.0]] * 5]), 0.5, 0.4)
    assert (v.action, v.polygon, v.v) == ("stop", "stop", 0.0)


def test_non_finite_commands_and_points_are_handled():
    m = approach()
    assert m.check(wall(2.0), math.nan, 0.0).action == "stop"
    pts = np.vstack([wall(2.0), [[np.nan, 0.0], [np.inf, 1.0]]])
    assert m.check(pts, 0.3, 0.0).action == "none"


def test_params_take_nav2_strings_and_name_bad_keys():
    mp, sources, polys = load_monitor({
        "footprint": "[[0.3, 0.2], [-0.3, 0.2], [-0.3, -0.2], [0.3, -0.2]]",
        "polygons": ["approach", "stop"],
        "approach": {"action_type": "approach"},
        "stop": {"type": "polygon", "action_type": "stop", "points": "[[0.1, 0.1], [-0.1, 0.1], [0, -0.1]]"},
    }, "cm.yaml")
    assert mp.footprint[0] == (0.3, 0.2) and polys[1][1].points[2] == (0.0, -0.1)
    assert padded(mp.footprint, 0.05)[0] == pytest.approx((0.35, 0.25))
    assert list(sources) == ["scan"]
    with pytest.raises(ConfigError) as e:
        load_monitor({"polygons": ["p"], "p": {"action_type": "brake"}, "cmd_vel_timeout": -1}, "cm.yaml")
    text = str(e.value)
    assert "cm.yaml" in text and "p.action_type" in text and "cmd_vel_timeout" in text
    with pytest.raises(ConfigError, match="footprint"):
        load_monitor({"polygons": ["p"], "p": {}}, "cm.yaml")  # no points and no footprint


# ---------------------------------------------------------------------- closed loop in the simulator
def _world_with_wall(x: float) -> World:
    return World.from_shapes({"bounds": [-1.0, -3.0, x + 1.0, 3.0], "resolution": 0.02,
                              "boxes": [{"center": [x + 0.1, 0.0], "size": [0.2, 4.0], "height": 1.0}]})


def _drive(monitor: CollisionMonitor | None, v: float, seconds: float = 6.0) -> Simulator:
    laser = LaserParams(samples=361, angle_min=-math.pi / 2, angle_max=math.pi / 2, x=0.1, rate=20.0)
    sim = Simulator(_world_with_wall(2.0), BaseParams(max_vel_x=1.0, acc_lim_x=1.0), laser, None,
                    SimulatorParams(seed=1), Pose2D())
    cmd = (v, 0.0)
    mount = laser.mount
    for _ in range(round(seconds / sim.params.dt)):
        if "laser" in sim.step() and monitor is not None:
            pts = mount.apply(scan_points(sim.scan()))
            verdict = monitor.check(pts, v, 0.0)
            cmd = (verdict.v, verdict.w)
        sim.base.set_cmd_vel(Twist.planar(*cmd), sim.time)  # the master keeps commanding full speed
    return sim


def test_a_robot_commanded_at_a_wall_stops_short_with_the_monitor_and_hits_it_without():
    fp = padded(P3AT_FOOTPRINT, 0.03)
    monitor = CollisionMonitor([("approach", PolygonParams(time_before_collision=0.6))], fp)
    safe = _drive(monitor, 0.7)
    front = safe.base.pose.x + 0.3302
    assert safe.base.collisions == 0
    assert 1.9 <= front < 2.0, f"stopped with its front at {front:.3f} m (wall at 2.0 m)"
    assert _drive(None, 0.7).base.collisions >= 1  # the same drive without the monitor hits the wall


# ---------------------------------------------------------------------- memory of the blind zone
def _scan_view(sensor: Pose2D, ranges: list[float]):
    from robot_side.safety.memory import View

    n = len(ranges)
    return View(sensor, -0.5, 1.0 / (n - 1), np.asarray(ranges, float))  # bearings -0.5 .. +0.5 rad


def test_memory_keeps_a_wall_the_depth_camera_no_longer_sees_and_drops_what_it_sees_through():
    from robot_side.safety.memory import PointMemory

    mem = PointMemory(max_age=1.0)
    wall_pts = np.array([[1.0, 0.0], [1.0, 0.1]])
    mem.update(wall_pts, _scan_view(Pose2D(), [1.0] * 11), now=0.0)
    # closer: the camera returns nothing (too close) -> the wall is still believed, long after max_age
    for k in range(1, 30):
        mem.update(np.zeros((0, 2)), _scan_view(Pose2D(0.6, 0.0, 0.0), [math.inf] * 11), now=0.5 * k)
    assert len(mem.points()) == 2
    # the camera now measures farther than the wall along those beams: the wall is gone
    mem.update(np.zeros((0, 2)), _scan_view(Pose2D(0.0, 0.0, 0.0), [3.0] * 11), now=20.0)
    assert len(mem.points()) == 0


def test_memory_forgets_points_outside_the_field_of_view_after_max_age():
    from robot_side.safety.memory import PointMemory

    mem = PointMemory(max_age=1.0)
    mem.update(np.array([[0.0, 1.0]]), _scan_view(Pose2D(), [math.inf] * 11), now=0.0)  # beside the robot
    mem.update(np.zeros((0, 2)), _scan_view(Pose2D(), [math.inf] * 11), now=0.5)
    assert len(mem.points()) == 1
    mem.update(np.zeros((0, 2)), _scan_view(Pose2D(), [math.inf] * 11), now=1.6)
    assert len(mem.points()) == 0


def _collision_time_every_point(poly, pts: np.ndarray, v: float, w: float) -> tuple[float, int]:
    """The approach prediction written out plainly: every point, every step (no reach filter)."""
    p, now = poly.p, points_in_polygon(pts[:, 0], pts[:, 1], poly.shape)
    blocking_now = int(np.count_nonzero(now & (v * pts[:, 0] > 0.0)))
    if blocking_now >= p.min_points:
        return 0.0, blocking_now
    fresh = pts[~now]
    for k in range(1, poly.n_steps + 1):
        t = k * p.simulation_time_step
        th = w * t
        x, y = (v * t, 0.0) if abs(w) < 1e-9 else (v / w * math.sin(th), v / w * (1.0 - math.cos(th)))
        dx, dy = fresh[:, 0] - x, fresh[:, 1] - y
        lx, ly = math.cos(th) * dx + math.sin(th) * dy, -math.sin(th) * dx + math.cos(th) * dy
        n = int(points_in_polygon(lx, ly, poly.shape).sum())
        if n >= p.min_points:
            return t - p.simulation_time_step, n
    return math.inf, 0


@pytest.mark.parametrize("shape", ["footprint", "circle"])
def test_points_beyond_reach_left_out_change_no_prediction(shape):
    """The approach check leaves out points no motion within the horizon can reach; random scenes and
    commands give the same collision time and count as testing every point at every step."""
    rng = np.random.default_rng(7)
    kw = {"type": "circle", "radius": 0.45} if shape == "circle" else {}
    m = CollisionMonitor([("approach", PolygonParams(time_before_collision=1.5, simulation_time_step=0.05,
                                                     min_points=3, **kw))], SQUARE)
    poly = m.polygons[0]
    for _ in range(200):
        pts = rng.uniform(-4.0, 4.0, (rng.integers(1, 300), 2))
        v, w = rng.uniform(-1.2, 1.2), rng.choice([0.0, rng.uniform(-2.0, 2.0)])
        got = poly.collision_time(pts, v, w)
        want = _collision_time_every_point(poly, pts, v, w)
        assert got[1] == want[1] and (got[0] == want[0] or abs(got[0] - want[0]) < 1e-9), (v, w, got, want)
