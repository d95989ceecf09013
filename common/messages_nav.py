"""Navigation messages: move_base's goals, status and plans, the costmaps' sensor reports.

Split from ``common.messages`` (which re-exports them); same conventions: frozen dataclasses in SI
units, registered by name with a schema version.
"""

from __future__ import annotations

from dataclasses import dataclass

from common.geometry import Pose2D
from common.messages import Header, Path, PoseStamped
from common.msg_registry import register

__all__ = ["GoalStatus", "MoveBaseStatus", "PlanRequest", "PlanResult", "MoveBaseGoal", "ObservationSourceStatus",
           "CostmapSensors", "CollisionMonitorState"]


@register("GoalStatus")
@dataclass(frozen=True)
class GoalStatus:
    """actionlib_msgs/GoalStatus codes."""

    PENDING = 0
    ACTIVE = 1
    PREEMPTED = 2
    SUCCEEDED = 3
    ABORTED = 4
    REJECTED = 5
    RECALLED = 8
    LOST = 9  # actionlib: the receiver does not know this goal id

    header: Header = Header()
    goal_id: str = ""
    status: int = 0
    text: str = ""


@register("MoveBaseStatus")
@dataclass(frozen=True)
class MoveBaseStatus:
    """move_base feedback: state machine state, why the robot is (not) moving, goal bookkeeping."""

    header: Header = Header()
    goal_id: str = ""
    status: int = 0  # GoalStatus code
    state: str = ""  # e.g. PLANNING, CONTROLLING, CLEARING
    reason: str = ""  # human-readable "why not moving" (empty when making progress)
    goal: PoseStamped = PoseStamped()  # requested goal, in the global frame
    goal_used: PoseStamped = PoseStamped()  # goal actually planned to
    goal_offset_m: float = 0.0  # distance between requested and used goal
    distance_to_goal_m: float = 0.0
    recovery_count: int = 0


@register("PlanRequest")
@dataclass(frozen=True)
class PlanRequest:
    """make_plan service request (nav_msgs/GetPlan): start and goal in any frame."""

    start: PoseStamped = PoseStamped()
    goal: PoseStamped = PoseStamped()
    tolerance: float = -1.0  # m; < 0 = the planner's default_tolerance


@register("PlanResult")
@dataclass(frozen=True)
class PlanResult:
    """make_plan service reply: the plan and the goal actually planned to."""

    path: Path = Path()
    goal_used: Pose2D = Pose2D()
    goal_offset_m: float = 0.0
    planning_time_s: float = 0.0


@register("MoveBaseGoal")
@dataclass(frozen=True)
class MoveBaseGoal:
    """A goal with a caller-chosen id (``move_base/goal``); ``move_base_simple/goal`` takes a bare pose."""

    goal_id: str = ""
    target_pose: PoseStamped = PoseStamped()


@register("ObservationSourceStatus")
@dataclass(frozen=True)
class ObservationSourceStatus:
    """One observation source of a costmap: is its sensor delivering? (an item of ``CostmapSensors``)."""

    OK, LATE, SILENT = "ok", "late", "silent"

    source: str = ""  # source name in observation_sources, e.g. "scan"
    layer: str = ""  # the obstacle / voxel layer it feeds
    topic: str = ""  # topic subscribed to (under the robot's key prefix)
    data_type: str = ""  # LaserScan / PointCloud / PointCloud2 (as configured)
    delivered: bool = False  # a reading reached the costmap since it started
    messages: int = 0  # messages received on the topic since start (used or not)
    age_s: float = 0.0  # since the last reading; since the costmap started when nothing was delivered
    expected_update_rate: float = 0.0  # s, ROS: max gap between readings (0: not checked)
    state: str = "ok"  # ok | late (expected_update_rate exceeded) | silent (nothing delivered since start)
    detail: str = ""  # one human line, e.g. "source 'scan' on topic 'front/scan' (LaserScan) has delivered ..."


@register("CostmapSensors")
@dataclass(frozen=True)
class CostmapSensors:
    """``<costmap>/sensors``: the state of every observation source, at 1 Hz and on every change."""

    header: Header = Header()
    costmap: str = ""  # e.g. global_costmap, local_costmap
    sources: tuple[ObservationSourceStatus, ...] = ()

    def problems(self) -> tuple[ObservationSourceStatus, ...]:
        return tuple(s for s in self.sources if s.state != ObservationSourceStatus.OK)


@register("CollisionMonitorState")
@dataclass(frozen=True)
class CollisionMonitorState:
    """What the robot-side collision monitor did to the last command, and why (nav2's
    CollisionMonitorState plus the numbers). ``action``: none, stop, slowdown, limit, approach,
    no_data (a source is silent: stop), stale_cmd (no command from the master: zero sent), disabled."""

    header: Header = Header()
    action: str = "none"
    polygon: str = ""
    reason: str = ""
    ratio: float = 1.0  # safe speed / commanded speed
    points: int = 0
    cmd_in_v: float = 0.0  # m/s, rad/s
    cmd_in_w: float = 0.0
    cmd_out_v: float = 0.0
    cmd_out_w: float = 0.0
