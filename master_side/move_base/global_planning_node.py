"""move_base's global planning on the bus: the global costmap and its frame, navfn plans from the robot's
pose for the planner thread (move_base::makePlan), published on ``move_base/global_plan``, and the
``make_plan`` service's plan between two given poses."""

from __future__ import annotations

import time

from common.bus import Node
from common.config import strip_frame
from common.geometry import Pose2D
from common.messages import Costmap, Header, Path, PlanRequest, PlanResult, PoseStamped
from common.tf import TFListener
from master_side.move_base.config import MoveBaseConfig
from master_side.move_base.planner_process import NavfnProcess
from master_side.planning.navfn import NavFn


class GlobalPlanning:
    """Owns the navfn worker process, the global costmap subscription and the last plan's result."""

    def __init__(self, node: Node, config: MoveBaseConfig, tf: TFListener) -> None:
        self.node, self.config, self.tf = node, config, tf
        self._global_frame = config.global_frame
        self.navfn = NavfnProcess(config.navfn)  # plans in a worker process: the control loop keeps its GIL
        self.result = PlanResult()
        self.global_costmap = node.subscribe("global_costmap/costmap", Costmap)
        self.gplan_pub = node.publisher("move_base/global_plan")

    @property
    def global_frame(self) -> str | None:
        """The global costmap's frame: configured, else that of its messages (None until one arrives)."""
        if self._global_frame is None:
            msg = self.global_costmap.latest()
            if msg is not None:
                self._global_frame = strip_frame(msg.header.frame_id)
        return self._global_frame

    def plan_now(self, goal: Pose2D):
        """One global plan from the robot's current pose (the planner thread; move_base::makePlan)."""
        msg = self.global_costmap.latest()
        if msg is None:
            raise RuntimeError("no global costmap received yet")
        frame = strip_frame(msg.header.frame_id)
        if frame != self.global_frame:
            raise RuntimeError(f"global costmap is in '{frame}', goals were given in '{self.global_frame}'")
        start = self.tf.buffer.lookup_pose2d(frame, self.config.base_frame, 0.0, 0.2)
        t0 = time.perf_counter()
        path = self.navfn.make_plan(msg.data, msg.resolution, (msg.origin.x, msg.origin.y), start, goal)
        used = self.navfn.last_goal_used or goal
        self.result = PlanResult(Path(Header(self.node.clock.now(), frame), path), used,
                                 goal.distance(used), time.perf_counter() - t0)
        self.gplan_pub.publish(self.result.path)
        return path, used

    def make_plan_service(self, req: PlanRequest) -> PlanResult:
        """The ``make_plan`` service: a plan between the request's poses, in any frames TF knows."""
        gf = self.global_frame
        if gf is None:
            raise RuntimeError("no global costmap received yet")
        start, goal = self._to_global(req.start, gf), self._to_global(req.goal, gf)
        tol = None if req.tolerance < 0 else req.tolerance
        msg = self.global_costmap.latest()
        t0 = time.perf_counter()
        path = NavFn(self.config.navfn).make_plan(msg.data, msg.resolution, (msg.origin.x, msg.origin.y),
                                                  start, goal, tol)
        return PlanResult(Path(Header(self.node.clock.now(), gf), path), goal, 0.0, time.perf_counter() - t0)

    def _to_global(self, ps: PoseStamped, gf: str) -> Pose2D:
        frame = strip_frame(ps.header.frame_id) or gf
        return self.tf.buffer.lookup_pose2d(gf, frame, 0.0, 0.5).compose(ps.pose.to_pose2d())

    def close(self) -> None:
        self.navfn.close()
