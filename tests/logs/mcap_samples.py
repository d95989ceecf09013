"""Sample messages of every type for the MCAP tests, and a field-by-field comparison with what ROS1 carries."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from common import messages as m
from common.geometry import Pose2D, Quaternion, Transform, Vector3
from deploy.logs import ros1_msgs

WALL = 1712345678.123456789


def _tf(x, y, z, yaw, roll=0.0) -> Transform:
    return Transform(Vector3(x, y, z), Quaternion.from_euler(roll, 0.0, yaw))


def ros1_samples() -> dict[str, object]:
    """topic -> one message of every type written as ROS1 (stamps: wall and simulated); same on every call."""
    rng = np.random.default_rng(7)
    h = m.Header(WALL, "laser")
    ranges = rng.uniform(0.1, 30.0, 361).astype(np.float32)
    ranges[[3, 40]] = np.inf
    ranges[7] = np.nan
    depth = rng.uniform(0.3, 8.0, (6, 8)).astype(np.float32)
    depth[0, 0], depth[1, 1] = 0.0, np.nan
    occ = rng.integers(-1, 101, (7, 5)).astype(np.int8)
    cost = np.arange(256, dtype=np.uint8)[: 16 * 16].reshape(16, 16)
    thetas = np.array([0.0, 1.0, -2.5, 3.1, -3.1, 0.5])
    plan = np.column_stack([np.linspace(-1, 4, 6), np.linspace(2, -3, 6), thetas])
    return {
        "scan": m.LaserScan(h, -2.35619449, 2.35619449, 0.0130899694, 1e-4, 0.1, 0.05, 30.0, ranges,
                            rng.uniform(0, 1000, 361).astype(np.float32)),
        "odom": m.Odometry(m.Header(12.345, "odom"), "base_link", _tf(1.5, -2.25, 0.0, 0.7, 0.01),
                           m.Twist(Vector3(0.4, 0.01, 0.0), Vector3(0.0, 0.0, -0.3))),
        "tf": m.TFMessage((m.TransformStamped(m.Header(12.5, "map"), "odom", _tf(0.1, 0.2, 0.0, 0.05)),
                           m.TransformStamped(m.Header(12.5, "odom"), "base_link", _tf(3.0, 1.0, 0.0, -1.2)))),
        "tf_static": m.TFMessage((m.TransformStamped(m.Header(0.0, "base_link"), "laser", _tf(0.2, 0, 0.3, 0)),)),
        "map": m.OccupancyGrid(m.Header(3.0, "map"), 0.05, Pose2D(-10.0, -7.5, 0.3), occ),
        "global_costmap/costmap": m.Costmap(m.Header(4.0, "map"), 0.1, Pose2D(-1.0, 2.0, 0.0), cost),
        "local_costmap/costmap/obstacle_layer": m.Costmap(m.Header(4.0, "odom"), 0.05, Pose2D(), cost.T.copy(),
                                                          layer="obstacle_layer"),
        "move_base/global_plan": m.Path(m.Header(5.0, "map"), plan),
        "move_base/local_plan": m.Path(m.Header(5.0, ""), plan[:0]),
        "camera/depth/image": m.DepthImage(m.Header(6.0, "camera_link"), depth),
        "camera/depth/camera_info": m.CameraInfo(m.Header(6.0, "camera_link"), 640, 480, 525.0, 526.5, 319.5, 239.5),
        "cmd_vel": m.Twist.planar(0.35, -0.2, 0.01),
        "move_base_simple/goal": m.PoseStamped(m.Header(7.0, "map"), _tf(2.0, 3.0, 0.0, 1.57)),
        "clock": m.Clock(123.456),
    }


def msgpack_samples() -> dict[str, object]:
    rng = np.random.default_rng(8)
    st = m.MoveBaseStatus(m.Header(8.0, "map"), "g1", m.GoalStatus.ACTIVE, "CONTROLLING", "blocked",
                          m.PoseStamped(m.Header(8.0, "map"), _tf(1, 2, 0, 0.5)), distance_to_goal_m=2.5)
    return {
        "move_base/status": st,
        "agent/robot/state": m.NodeState(m.Header(WALL, ""), "move_base", "RUNNING", 123, 2, "ok"),
        "camera/depth/points": m.PointCloud(m.Header(6.0, "camera_link"), rng.normal(size=(50, 3)).astype(np.float32)),
        "local_costmap/footprint": m.PolygonStamped(m.Header(9.0, "odom"), np.ones((4, 2), np.float32)),
        "move_base/loop_time": m.Scalar(m.Header(9.0), 0.02),
        "motor_state": m.MotorState(m.Header(1.0), True),
        "ping": m.Empty(),
    }


def expected_stamp(t: float) -> float:
    sec, nsec = ros1_msgs.time_parts(t)
    return sec + nsec * 1e-9


def assert_ros1_equal(got, want, path: str = "msg") -> None:
    """Field by field, with what ROS1 can carry: float32 scalars (LaserScan, resolution) compared as float32,
    stamps to the nanosecond, yaw-only orientations as angles, Costmap costs through costmap_2d's table."""
    assert type(got) is type(want), f"{path}: {type(got).__name__} != {type(want).__name__}"
    if isinstance(want, m.Header):
        assert got.frame_id == want.frame_id, path
        assert got.stamp == expected_stamp(want.stamp), f"{path}.stamp {got.stamp} != {want.stamp}"
        return
    if isinstance(want, m.Costmap):
        ros = ros1_msgs.COST_TO_OCC[want.data]
        special = np.isin(want.data, (0, 253, 254, 255))
        assert got.data.dtype == np.uint8 and got.data.shape == want.data.shape, path
        assert np.array_equal(got.data[special], want.data[special]), f"{path}: special costs changed"
        assert np.abs(got.data.astype(int) - want.data.astype(int)).max() <= 1, f"{path}: costs off by > 1"
        assert np.array_equal(ros1_msgs.COST_TO_OCC[got.data], ros), f"{path}: occupancy changed"
        want = dataclasses.replace(want, data=got.data)
    if isinstance(want, m.Path):
        assert got.poses.shape == want.poses.shape and got.poses.dtype == np.float64, path
        assert np.array_equal(got.poses[:, :2], want.poses[:, :2]), path
        d = np.angle(np.exp(1j * (got.poses[:, 2] - want.poses[:, 2])))
        assert np.abs(d).max(initial=0) < 1e-12, f"{path}.poses theta"
        want = dataclasses.replace(want, poses=got.poses)
    if isinstance(want, m.Pose2D):
        assert (got.x, got.y) == (want.x, want.y), path
        assert abs(math.remainder(got.theta - want.theta, math.tau)) < 1e-12, f"{path}.theta"
        return
    for f in dataclasses.fields(want):
        a, b, p = getattr(got, f.name), getattr(want, f.name), f"{path}.{f.name}"
        if dataclasses.is_dataclass(b):
            assert_ros1_equal(a, b, p)
        elif isinstance(b, tuple):
            assert len(a) == len(b), p
            for i, (x, y) in enumerate(zip(a, b)):
                assert_ros1_equal(x, y, f"{p}[{i}]")
        elif isinstance(b, np.ndarray):
            assert m.msg_equal(a, b), p
        elif isinstance(want, (m.LaserScan, m.OccupancyGrid, m.Costmap)) and isinstance(b, float):
            assert np.float32(a) == np.float32(b), f"{p}: {a} != {b} as float32"
            assert a == float(str(np.float32(b))), f"{p}: {a} is not the shortest float32 decimal"
        elif isinstance(want, m.Clock):
            assert a == expected_stamp(b), p
        else:
            assert a == b, f"{p}: {a!r} != {b!r}"
