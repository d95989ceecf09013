"""Bus messages: frozen dataclasses in SI units (metres, radians, seconds).

Every message type is registered by name with a schema version; ``common.codec`` encodes them.
Array fields are numpy arrays whose dtype and number of dimensions are declared with ``Arr``
and checked on decode. ROS field semantics are kept where ROS has the message.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from common.geometry import Pose, Pose2D, Quaternion, Transform, Vector3
from common.msg_registry import F32_1, F32_2, F64_2, I8_2, REGISTRY, U8_2, Arr, empty_f32, msg_equal, register

__all__ = [
    "Arr", "REGISTRY", "register", "msg_equal", "Header", "Vector3", "Quaternion", "Pose2D", "Transform",
    "Pose", "Twist", "Odometry", "LaserScan", "DepthImage", "CameraInfo", "PointCloud", "OccupancyGrid",
    "Costmap", "Path", "PoseStamped", "TransformStamped", "TFMessage", "GoalStatus", "MotorState",
    "BatteryState", "Clock", "PolygonStamped", "Text", "Empty", "Collision", "NodeState", "Scalar",
    "MoveBaseStatus", "PlanRequest", "PlanResult", "MoveBaseGoal", "ObservationSourceStatus", "CostmapSensors",
    "CollisionMonitorState", "SonarArray", "SpawnBox", "TopicStats", "NodeStats", "empty_f32",
]


for _name, _cls in (("Vector3", Vector3), ("Quaternion", Quaternion), ("Pose2D", Pose2D), ("Transform", Transform)):
    register(_name)(_cls)



@register("Header")
@dataclass(frozen=True)
class Header:
    stamp: float = 0.0  # seconds (wall or simulated clock)
    frame_id: str = ""


@register("Twist")
@dataclass(frozen=True)
class Twist:
    linear: Vector3 = Vector3()  # m/s
    angular: Vector3 = Vector3()  # rad/s

    @staticmethod
    def planar(vx: float = 0.0, wz: float = 0.0, vy: float = 0.0) -> Twist:
        return Twist(Vector3(vx, vy, 0.0), Vector3(0.0, 0.0, wz))

    def is_zero(self) -> bool:
        return self.linear == Vector3() and self.angular == Vector3()


@register("Odometry")
@dataclass(frozen=True)
class Odometry:
    header: Header = Header()  # frame_id: odom
    child_frame_id: str = "base_link"
    pose: Transform = Transform()
    twist: Twist = Twist()  # in child_frame_id

    @property
    def pose2d(self) -> Pose2D:
        return self.pose.to_pose2d()


@register("LaserScan")
@dataclass(frozen=True)
class LaserScan:
    """ROS sensor_msgs/LaserScan semantics; ``ranges`` float32, +inf means no return."""

    header: Header = Header()
    angle_min: float = 0.0
    angle_max: float = 0.0
    angle_increment: float = 0.0
    time_increment: float = 0.0
    scan_time: float = 0.0
    range_min: float = 0.0
    range_max: float = 0.0
    ranges: F32_1 = field(default_factory=empty_f32)
    intensities: F32_1 = field(default_factory=empty_f32)

    def angles(self) -> np.ndarray:
        return self.angle_min + self.angle_increment * np.arange(len(self.ranges), dtype=np.float64)


@register("DepthImage")
@dataclass(frozen=True)
class DepthImage:
    """Depth in metres along the optical axis, float32 (H, W); 0 or NaN = invalid. Optical frame."""

    header: Header = Header()
    depth: F32_2 = field(default_factory=lambda: np.zeros((0, 0), np.float32))


@register("CameraInfo")
@dataclass(frozen=True)
class CameraInfo:
    """Pinhole intrinsics in pixels (no distortion model)."""

    header: Header = Header()
    width: int = 0
    height: int = 0
    fx: float = 0.0
    fy: float = 0.0
    cx: float = 0.0
    cy: float = 0.0


@register("PointCloud")
@dataclass(frozen=True)
class PointCloud:
    header: Header = Header()
    points: F32_2 = field(default_factory=lambda: np.zeros((0, 3), np.float32))  # (N, 3) metres


@register("OccupancyGrid")
@dataclass(frozen=True)
class OccupancyGrid:
    """ROS nav_msgs/OccupancyGrid: ``data`` int8 (height, width), -1 unknown, 0..100 occupancy.

    Row 0 is the row at ``origin`` (lowest y), as in ROS (not image order).
    """

    header: Header = Header()
    resolution: float = 0.05  # m/cell
    origin: Pose2D = Pose2D()  # pose of cell (0, 0)'s corner in header.frame_id
    data: I8_2 = field(default_factory=lambda: np.zeros((0, 0), np.int8))

    @property
    def width(self) -> int:
        return int(self.data.shape[1])

    @property
    def height(self) -> int:
        return int(self.data.shape[0])


@register("Costmap")
@dataclass(frozen=True)
class Costmap:
    """A costmap_2d grid: uint8 (height, width), 0 free .. 253 inscribed, 254 lethal, 255 unknown."""

    header: Header = Header()
    resolution: float = 0.05
    origin: Pose2D = Pose2D()
    data: U8_2 = field(default_factory=lambda: np.zeros((0, 0), np.uint8))
    layer: str = ""  # "" for the master grid, else the layer name


@register("PoseStamped")
@dataclass(frozen=True)
class PoseStamped:
    header: Header = Header()
    pose: Transform = Transform()


@register("Path")
@dataclass(frozen=True)
class Path:
    """A planar path: ``poses`` float64 (N, 3) rows of (x, y, theta) in header.frame_id."""

    header: Header = Header()
    poses: F64_2 = field(default_factory=lambda: np.zeros((0, 3)))


@register("TransformStamped")
@dataclass(frozen=True)
class TransformStamped:
    header: Header = Header()  # frame_id = parent
    child_frame_id: str = ""
    transform: Transform = Transform()


@register("TFMessage")
@dataclass(frozen=True)
class TFMessage:
    transforms: tuple[TransformStamped, ...] = ()


@register("MotorState")
@dataclass(frozen=True)
class MotorState:
    header: Header = Header()
    enabled: bool = False


@register("BatteryState")
@dataclass(frozen=True)
class BatteryState:
    header: Header = Header()
    voltage: float = 0.0  # V
    percentage: float = float("nan")  # 0..1, NaN if unknown


@register("Clock")
@dataclass(frozen=True)
class Clock:
    clock: float = 0.0  # simulated seconds


@register("PolygonStamped")
@dataclass(frozen=True)
class PolygonStamped:
    header: Header = Header()
    points: F32_2 = field(default_factory=lambda: np.zeros((0, 2), np.float32))  # (N, 2) metres


@register("Text")
@dataclass(frozen=True)
class Text:
    header: Header = Header()
    data: str = ""


@register("Empty")
@dataclass(frozen=True)
class Empty:
    pass


@register("Scalar")
@dataclass(frozen=True)
class Scalar:
    header: Header = Header()
    value: float = 0.0


@register("Collision")
@dataclass(frozen=True)
class Collision:
    header: Header = Header()
    count: int = 0  # collisions since start
    x: float = 0.0  # contact point in header.frame_id
    y: float = 0.0


@register("BumperState")
@dataclass(frozen=True)
class BumperState:
    """p2os_msgs/BumperState: each segment of the front and rear bumpers, pressed or not (a Pioneer's SIP
    stall/bump bytes). Segments are numbered from the robot's left end (+y) to its right end."""

    header: Header = Header()
    front_bumpers: tuple[bool, ...] = ()
    rear_bumpers: tuple[bool, ...] = ()


@register("SonarArray")
@dataclass(frozen=True)
class SonarArray:
    """p2os_msgs/SonarArray: the latest range of each sonar, indexed by sonar number, metres (ranges_count
    is ``len(ranges)``). A sonar with no echo reports its maximum range; +inf: not heard from yet (P2OS)."""

    header: Header = Header()
    ranges: tuple[float, ...] = ()


@register("SpawnBox")
@dataclass(frozen=True)
class SpawnBox:
    """Simulator only (as Gazebo's spawn_model): a box appears. ``header.frame_id`` ``map`` = the world,
    the base frame = relative to the robot's true pose when the simulator receives it."""

    header: Header = Header()
    x: float = 0.0  # centre, m
    y: float = 0.0
    yaw: float = 0.0
    size_x: float = 0.2
    size_y: float = 0.2
    height: float = 1.0


@register("NodeState")
@dataclass(frozen=True)
class NodeState:
    """An agent's view of one managed node process."""

    header: Header = Header()
    node: str = ""
    state: str = ""  # WAITING, STARTING, RUNNING, RESTARTING, EXITED, FAILED, STOPPED
    pid: int = 0
    restarts: int = 0
    detail: str = ""


@register("TopicStats")
@dataclass(frozen=True)
class TopicStats:
    """What one subscription of a node has seen since it started (every payload lands in one count)."""

    topic: str = ""
    msg_type: str = ""  # "*" = any type
    received: int = 0  # valid messages
    malformed: int = 0  # payloads that did not decode as the type (dropped)
    invalid: int = 0  # decoded but unusable (NaN position, zero quaternion, empty map ...; dropped)
    dropped: int = 0  # valid messages replaced by newer ones before the node used them
    errors: int = 0  # messages whose callback raised (a bug: reported, the node goes on)


@register("NodeStats")
@dataclass(frozen=True)
class NodeStats:
    """Answer of the ``node_stats/<node>`` service every node serves."""

    header: Header = Header()
    node: str = ""
    pid: int = 0
    topics: tuple[TopicStats, ...] = ()


# navigation messages live in their own module (kept importable from here)
from common.messages_nav import (  # noqa: E402
    CollisionMonitorState,
    CostmapSensors,
    GoalStatus,
    MoveBaseGoal,
    MoveBaseStatus,
    ObservationSourceStatus,
    PlanRequest,
    PlanResult,
)
