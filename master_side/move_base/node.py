"""move_base node: goals in, cmd_vel out (thin adapter around MoveBaseMachine).

Config mapping (paths relative to the config file, or inline mappings):
  move_base: move_base.yaml            # ROS move_base parameters
  local_planner: dwa_planner_ros.yaml  # DWAPlannerROS: / TrajectoryPlannerROS: section inside
  global_planner: {}                   # NavfnROS parameters (optional)
  costmap_common: costmap_common_params.yaml   # for the footprint
  local_costmap: local_costmap_params.yaml     # for the local frame

Topics: in ``move_base_simple/goal`` (PoseStamped, any frame), ``move_base/goal`` (MoveBaseGoal, with
an id), ``move_base/cancel`` (any message),
``odom``, ``global_costmap/costmap``, ``local_costmap/costmap``, TF. Out ``cmd_vel``,
``move_base/status`` + ``move_base/result`` (MoveBaseStatus), ``move_base/global_plan``,
``move_base/local_plan`` (Path), ``move_base/current_goal`` (PoseStamped), ``move_base/loop_time``.
Service ``make_plan`` (PlanRequest -> PlanResult), as ROS move_base offers.
"""

from __future__ import annotations

import itertools
import threading
import time

import numpy as np

from common.bus import Node
from common.config import ConfigError, include, load_params, strip_frame
from common.geometry import Pose2D
from common.messages import (
    Costmap,
    GoalStatus,
    Header,
    MoveBaseGoal,
    MoveBaseStatus,
    Odometry,
    Path,
    PlanRequest,
    PlanResult,
    PoseStamped,
    Scalar,
    Twist,
)
from common.tf import TFListener
from master_side.costmap.footprint import inscribed_circumscribed, pad_footprint
from master_side.costmap.params import load_costmap_config
from master_side.move_base.controller import LocalController
from master_side.move_base.params import MoveBaseParams
from master_side.move_base.recovery import default_recoveries
from master_side.move_base.state_machine import MoveBaseMachine, State
from master_side.planning.local.dwa import DWAPlanner, DWAPlannerParams
from master_side.planning.local.trajectory_planner import TrajectoryPlanner, TrajectoryPlannerParams
from master_side.planning.navfn import NavFn, NavfnParams

TERMINAL = (GoalStatus.SUCCEEDED, GoalStatus.ABORTED, GoalStatus.PREEMPTED)


def build_local_planner(kind: str, mapping: dict, source: str, controller_frequency: float | None = None):
    """The local planner of ``kind`` from its ROS section. Like ROS (the planners look
    ``controller_frequency`` up the parameter tree and find move_base's), a section without its own
    ``controller_frequency`` gets move_base's: it sets the planner's control period (dynamic window,
    braking and the stopping profile of the final rotation)."""
    if kind.startswith("dwa"):
        section, cls, planner = "DWAPlannerROS", DWAPlannerParams, DWAPlanner
    else:
        section, cls, planner = "TrajectoryPlannerROS", TrajectoryPlannerParams, TrajectoryPlanner
    data = mapping.get(section, mapping if section not in mapping and mapping else {})
    if controller_frequency is not None and "controller_frequency" not in (data or {}):
        data = {**(data or {}), "controller_frequency": controller_frequency}
    return planner(load_params(cls, data, source, section))


class MoveBaseNode:
    def __init__(self, node: Node, cfg: dict, source: str) -> None:
        self.node = node
        mb, mb_src = include(cfg.get("move_base"), source, "move_base")
        self.params = p = load_params(MoveBaseParams, mb, mb_src, "move_base")
        common, common_src = include(cfg.get("costmap_common"), source, "costmap_common")
        local, local_src = include(cfg.get("local_costmap"), source, "local_costmap")
        lc = load_costmap_config(common, local, (common_src, local_src), name="local_costmap")
        self.local_frame = strip_frame(lc.costmap.global_frame)
        self.global_frame, self.base_frame = strip_frame(p.global_frame), strip_frame(p.robot_base_frame)
        lp, lp_src = include(cfg.get("local_planner"), source, "local_planner")
        # The local planner checks the footprint against cells: obstacles are marked at the cell
        # that holds the hit, so the footprint is padded by one and a half cells of safety margin.
        margin = 1.5 * lc.costmap.resolution
        self.controller = LocalController(build_local_planner(p.base_local_planner.split("/")[0], lp, lp_src,
                                                              p.controller_frequency),
                                          pad_footprint(np.asarray(lc.footprint, float), margin))
        gp, gp_src = include(cfg.get("global_planner"), source, "global_planner")
        self.navfn = NavFn(load_params(NavfnParams, gp.get("NavfnROS", gp), gp_src, "NavfnROS"))
        self.tf = TFListener(node)
        self.lock = threading.RLock()
        self.cmd_lock = threading.Lock()  # orders cycle commands against cancel's immediate stop
        self._cancels = 0
        self.machine = MoveBaseMachine(p, self._plan, self.controller,
                                       default_recoveries(p, self._clear_costmaps, self._blocked,
                                                          inscribed_circumscribed(np.asarray(lc.footprint))[1]))
        self.ids = itertools.count(1)
        self.goal_msg: PoseStamped | None = None
        self.result = PlanResult()
        self._last_terminal = None
        self._pose_global: Pose2D | None = None
        self.odom = node.subscribe("odom", Odometry)
        self.global_costmap = node.subscribe("global_costmap/costmap", Costmap)
        self.local_costmap = node.subscribe("local_costmap/costmap", Costmap)
        self.cmd = node.publisher("cmd_vel")
        self.status_pub = node.publisher("move_base/status")
        self.result_pub = node.publisher("move_base/result", latched=True)
        self.gplan_pub = node.publisher("move_base/global_plan")
        self.lplan_pub = node.publisher("move_base/local_plan")
        self.goal_pub = node.publisher("move_base/current_goal", latched=True)
        self.loop_pub = node.publisher("move_base/loop_time")
        node.subscribe("move_base_simple/goal", PoseStamped, callback=self._on_goal, mode="queue")
        node.subscribe("move_base/goal", MoveBaseGoal, mode="queue",
                       callback=lambda g: self._on_goal(g.target_pose, g.goal_id))
        node.subscribe("move_base/cancel", None, callback=lambda _m: self.cancel(), mode="queue")
        node.service("make_plan", self._make_plan_service, PlanRequest)
        self.timer = node.timer(1.0 / p.controller_frequency, self.cycle)

    # -- inputs ------------------------------------------------------------------------------------
    def _on_goal(self, msg: PoseStamped, goal_id: str = "") -> None:
        frame = strip_frame(msg.header.frame_id) or self.global_frame
        now = self.node.clock.now()
        try:
            to_global = self.tf.buffer.lookup_pose2d(self.global_frame, frame, 0.0, 1.0)
        except Exception as e:  # noqa: BLE001 - any TF problem rejects the goal with the reason
            self._publish_status(GoalStatus.REJECTED, f"goal rejected: no transform {self.global_frame} <- "
                                                      f"{frame}: {e}", terminal=True, gid=goal_id or "rejected")
            return
        goal = to_global.compose(msg.pose.to_pose2d())
        with self.lock:
            gid = goal_id or f"goal-{next(self.ids)}"
            self.goal_msg = PoseStamped(Header(now, self.global_frame), goal.to_transform())
            self.result = PlanResult()
            self.machine.set_goal(gid, goal, now)
        self.goal_pub.publish(self.goal_msg)
        self.node.log.info("new goal %s: (%.2f, %.2f, %.2f) in %s (given in %s)", gid, goal.x, goal.y,
                           goal.theta, self.global_frame, frame)

    def cancel(self) -> None:
        # Stop first: the control cycle may hold self.lock for a while (a recovery's costmap-clear
        # service calls run inside it), and cancel must zero cmd_vel at once. The cycle checks the
        # cancel count under cmd_lock before it publishes, so it cannot send a stale command after this.
        with self.cmd_lock:
            self._cancels += 1
            self.cmd.publish(Twist())
        with self.lock:
            self.machine.cancel(self.node.clock.now())
            self.cmd.publish(Twist())
            self._report(None)

    # -- collaborators -------------------------------------------------------------------------------
    def _plan(self, start: Pose2D, goal: Pose2D):
        msg = self.global_costmap.latest()
        if msg is None:
            raise RuntimeError("no global costmap received yet")
        frame = strip_frame(msg.header.frame_id)
        if frame != self.global_frame:
            raise RuntimeError(f"global costmap is in '{frame}', move_base global_frame is '{self.global_frame}'")
        t0 = time.perf_counter()
        path = self.navfn.make_plan(msg.data, msg.resolution, (msg.origin.x, msg.origin.y), start, goal)
        used = self.navfn.last_goal_used or goal
        self.result = PlanResult(Path(Header(self.node.clock.now(), frame), path), used,
                                 goal.distance(used), time.perf_counter() - t0)
        self.gplan_pub.publish(self.result.path)
        return path, used

    def _make_plan_service(self, req: PlanRequest) -> PlanResult:
        start = self._to_global(req.start)
        goal = self._to_global(req.goal)
        tol = None if req.tolerance < 0 else req.tolerance
        msg = self.global_costmap.latest()
        if msg is None:
            raise RuntimeError("no global costmap received yet")
        t0 = time.perf_counter()
        path = self.navfn.make_plan(msg.data, msg.resolution, (msg.origin.x, msg.origin.y), start, goal, tol)
        used = self.navfn.last_goal_used or goal
        return PlanResult(Path(Header(self.node.clock.now(), self.global_frame), path), used,
                          goal.distance(used), time.perf_counter() - t0)

    def _to_global(self, ps: PoseStamped) -> Pose2D:
        frame = strip_frame(ps.header.frame_id) or self.global_frame
        return self.tf.buffer.lookup_pose2d(self.global_frame, frame, 0.0, 0.5).compose(ps.pose.to_pose2d())

    def _clear_costmaps(self, reset_distance: float) -> None:
        for name in ("local_costmap", "global_costmap"):
            try:
                self.node.call(f"{name}/clear", Scalar(value=reset_distance), timeout=1.0)
            except Exception as e:  # noqa: BLE001 - recovery goes on without it
                self.node.log.warning("could not clear %s: %s", name, e)

    def _blocked(self, pose_global: Pose2D) -> bool:
        """Would the footprint hit a lethal cell at this (global) pose? Checked on the local costmap."""
        lp, g = self.controller.local_pose, self._pose_global
        if lp is None or g is None:
            return True
        return self.controller.footprint_blocked(Pose2D(lp.x, lp.y, lp.theta + pose_global.theta - g.theta))

    # -- the control cycle ---------------------------------------------------------------------------
    def _robot_pose(self, now: float):
        """(global pose, local pose, local_from_global, problem)."""
        tol = self.params.transform_tolerance
        try:
            g = self.tf.buffer.lookup(self.global_frame, self.base_frame, 0.0)
            lo = self.tf.buffer.lookup(self.local_frame, self.base_frame, 0.0)
            lg = self.tf.buffer.lookup_pose2d(self.local_frame, self.global_frame, 0.0)
        except Exception as e:  # noqa: BLE001
            return None, None, None, f"no robot pose: {e}"
        for ts, a, b in ((g, self.global_frame, self.base_frame), (lo, self.local_frame, self.base_frame)):
            age = now - ts.header.stamp
            if ts.header.stamp > 0 and age > tol:
                return None, None, None, (f"stale TF: {a} <- {b} is {age:.2f} s old (transform_tolerance "
                                          f"{tol:.2f} s){self._slowest_edge(now)}")
        return g.transform.to_pose2d(), lo.transform.to_pose2d(), lg, ""

    def _slowest_edge(self, now: float) -> str:
        edges = [e for e in self.tf.buffer.edges() if not e.static]
        if not edges:
            return ""
        e = max(edges, key=lambda e: now - e.latest_stamp)
        return f"; oldest edge {e.parent} -> {e.child} ({now - e.latest_stamp:.2f} s, from {e.publisher or '?'})"

    def cycle(self) -> None:
        t0 = time.perf_counter()
        now = self.node.clock.now()
        pose, local_pose, lfg, problem = self._robot_pose(now)
        self._pose_global = pose
        odom = self.odom.latest()
        vel = (odom.twist.linear.x, odom.twist.linear.y, odom.twist.angular.z) if odom else (0.0, 0.0, 0.0)
        cm = self.local_costmap.latest()
        costmap = None if cm is None else (cm.data, cm.resolution, (cm.origin.x, cm.origin.y))
        cancels = self._cancels
        with self.lock:
            if local_pose is not None:
                self.controller.update(local_pose, lfg, costmap)
            d = self.machine.tick(now, pose, vel, problem)
            if self.machine.state is not State.IDLE or d.event:
                with self.cmd_lock:
                    if cancels == self._cancels:  # else a cancel came in during this cycle: stay stopped
                        self.cmd.publish(Twist.planar(d.cmd[0], d.cmd[2], d.cmd[1]))
            if d.event:
                self.node.log.info("%s", d.event)
            self._report(pose)
        last = self.controller.last
        if self.machine.state is State.CONTROLLING and last is not None and last.trajectory is not None:
            traj = np.asarray(last.trajectory, float).reshape(-1, 3)
            self.lplan_pub.publish(Path(Header(now, self.local_frame), traj))
        self.loop_pub.publish(Scalar(Header(now, ""), time.perf_counter() - t0))

    def _report(self, pose: Pose2D | None) -> None:
        m = self.machine
        dist = 0.0
        if pose is not None and m.goal is not None:
            dist = pose.distance(m.goal.pose)
        terminal = m.state is State.IDLE and m.status in TERMINAL
        self._publish_status(m.status, m.reason, terminal, dist)

    def _publish_status(self, status: int, reason: str, terminal: bool, dist: float = 0.0,
                        gid: str | None = None) -> None:
        m = self.machine
        now = self.node.clock.now()
        if gid is None:
            gid = m.goal.goal_id if m.goal else ""
        used = self.result.goal_used
        msg = MoveBaseStatus(Header(now, self.global_frame), gid, status, m.state.value, reason,
                             self.goal_msg or PoseStamped(),
                             PoseStamped(Header(now, self.global_frame), used.to_transform()),
                             self.result.goal_offset_m, dist, m.recovery_index)
        self.status_pub.publish(msg)
        if terminal and self._last_terminal != (gid, status):
            self._last_terminal = (gid, status)
            self.result_pub.publish(msg)

    def close(self) -> None:
        self.timer.cancel()
        self.cmd.publish(Twist())
        self.tf.close()


def start(node: Node, cfg: dict, source: str) -> MoveBaseNode:
    unknown = set(cfg) - {"move_base", "local_planner", "global_planner", "costmap_common", "local_costmap"}
    if unknown:
        raise ConfigError(source, sorted(unknown)[0], "unknown key (known: move_base, local_planner, "
                                                      "global_planner, costmap_common, local_costmap)")
    return MoveBaseNode(node, cfg, source)


if __name__ == "__main__":
    from common.runner import node_main

    node_main("move_base", start)
