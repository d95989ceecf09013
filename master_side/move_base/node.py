"""move_base node: goals in, cmd_vel out (thin adapter around MoveBaseMachine).

Config: see ``master_side.move_base.config`` (move_base, local_planner, global_planner, costmap_common,
local_costmap, global_costmap). Frames as in ROS: plans in the global costmap's ``global_frame``
(from ``global_costmap`` if given, else from the global costmap messages), controls in the local
costmap's; the robot frame and TF tolerance are the costmaps'. The global planner runs on its own
thread (``planner_thread``), so a slow plan never delays the control cycle; the thread hands the
work to a navfn worker process (``planner_process``), so it does not take the interpreter lock either.

Topics: in ``move_base_simple/goal`` (PoseStamped, any frame), ``move_base/goal`` (MoveBaseGoal, with
an id), ``move_base/cancel`` (any message), ``odom``, ``global_costmap/costmap``,
``local_costmap/costmap``, ``<costmap>/sensors`` (a silent or late sensor stops the robot and is named
in the status), TF. Out ``cmd_vel``, ``move_base/status`` + ``move_base/result`` (MoveBaseStatus),
``move_base/global_plan``, ``move_base/local_plan`` (Path), ``move_base/current_goal`` (PoseStamped),
``move_base/loop_time``, ``move_base/cmd_trace`` (Scalar after each cycle's cmd_vel: value = header stamp
of the local costmap it was computed from, -1 without one; bench/loop.py). Service ``make_plan``
(PlanRequest -> PlanResult), as ROS move_base offers. Acknowledged commands (common/delivery.py):
services ``move_base/send_goal`` (MoveBaseGoal -> MoveBaseStatus: the goal's state once taken in) and
``move_base/cancel_goal`` (Text with a goal id, or empty for any -> MoveBaseStatus). A goal id seen before
(a sender's retry, on either path) is answered with that goal's state and never restarts it. Global
planning on the bus (the planner thread's plan call, the service) is ``master_side.move_base.global_planning_node``.
"""

from __future__ import annotations

import collections
import itertools
import sys
import threading
import time

import numpy as np

from common.bus import Node
from common.config import strip_frame
from common.geometry import Pose2D
from common.messages import (
    Collision,
    CollisionMonitorState,
    Costmap,
    CostmapSensors,
    GoalStatus,
    Header,
    MoveBaseGoal,
    MoveBaseStatus,
    Odometry,
    Path,
    PlanRequest,
    PlanResult,
    PointCloud,
    PoseStamped,
    Scalar,
    Text,
    Twist,
)
from common.tf import TFListener
from master_side.costmap.health import SensorHealth
from master_side.move_base.config import check, load_move_base_config
from master_side.move_base.controller import LocalController
from master_side.move_base.global_planning_node import GlobalPlanning
from master_side.move_base.planner_thread import PlannerThread
from master_side.move_base.recovery import recoveries_from_params
from master_side.move_base.robot_inputs import collision_hint, robot_pose, safety_override
from master_side.move_base.stall_marks import StallMarker
from master_side.move_base.state_machine import MoveBaseMachine, State, Trigger
from master_side.planning.warmup import warm_local_planners

TERMINAL = (GoalStatus.SUCCEEDED, GoalStatus.ABORTED, GoalStatus.PREEMPTED)
NO_CMD_ROUTE = "cmd_vel reaches no subscriber (no route to the robot's base or collision monitor)"
SEEN_GOALS = 256  # goal ids remembered (with their last answer) so that a resent goal is not restarted
SENSORS_MAX_AGE = 3.0  # wall s without a costmap's sensor report (sent at 1 Hz) before it counts as not reporting

__all__ = ["MoveBaseNode", "start", "check"]


class MoveBaseNode:
    def __init__(self, node: Node, cfg: dict, source: str) -> None:
        self.node = node
        c = self.config = load_move_base_config(cfg, source)
        self.params = p = c.params
        self.local_frame, self.base_frame = strip_frame(c.local_frame), c.base_frame
        warm_local_planners()  # numba's start and the kernel loads now, not in the first control cycle
        self.controller = LocalController(c.make_local_planner(), c.footprint)
        self.tf = TFListener(node)
        self.planning = GlobalPlanning(node, c, self.tf)
        self.lock = threading.RLock()
        self.intake_lock = threading.Lock()  # one goal taken in at a time (a TF wait inside: not self.lock)
        self.cmd_lock = threading.Lock()  # orders cycle commands against cancel's immediate stop
        self._cancelling = 0  # cancels under way: no cycle publishes meanwhile (see cancel())
        self.planner = PlannerThread(self.planning.plan_now, p.planner_frequency, node.clock.now, "move_base:planner")
        recoveries = recoveries_from_params(p, c.recovery_namespaces, source, self._clear_costmaps, self._blocked,
                                            c.circumscribed_radius, c.rotate, self._local_view, c.bare_footprint,
                                            node.log.info, self._stalled_on,
                                            lambda cmd: self.machine.note_stall(cmd),
                                            c.rotation_center_x)
        self.machine = MoveBaseMachine(p, self.planner, self.controller, recoveries)
        self.ids = itertools.count(1)
        self.goal_msg: PoseStamped | None = None
        self._last_terminal: tuple[str, int] | None = None
        self._answers: collections.OrderedDict[str, MoveBaseStatus] = collections.OrderedDict()
        self._pose_global: Pose2D | None = None
        self._blind = ""
        self._last_event = ("", float("-inf"), 0)
        self.health = SensorHealth(required=("local_costmap",))
        self.odom = node.subscribe("odom", Odometry)
        self.local_costmap = node.subscribe("local_costmap/costmap", Costmap, callback=self._on_local_costmap)
        for name in ("local_costmap", "global_costmap"):
            # the costmaps report at 1 Hz of wall time (also while a simulated clock stands or runs faster):
            # a report's age is wall time since it came, not simulated time since its stamp
            node.subscribe(f"{name}/sensors", CostmapSensors, mode="queue",
                           callback=lambda m: self.health.update(m, time.monotonic()))
        self.cmd = node.publisher("cmd_vel")
        self.safety = node.subscribe("collision_monitor/state", CollisionMonitorState)  # the robot's monitor
        self.collision = node.subscribe("collision", Collision)  # a simulated robot's contacts (latched)
        self.status_pub = node.publisher("move_base/status")
        self.result_pub = node.publisher("move_base/result", latched=True)
        self.lplan_pub = node.publisher("move_base/local_plan")
        self.goal_pub = node.publisher("move_base/current_goal", latched=True)
        self.loop_pub = node.publisher("move_base/loop_time")
        self.trace_pub = node.publisher("move_base/cmd_trace")
        self.stall_marker = None
        if p.stall_marks:  # zenav: where a stall pushed a flank, for the local costmap (stall_marks.py)
            stall_pub = node.publisher("stall_pointcloud")
            self.stall_marker = StallMarker(c.bare_footprint, lambda pts, t: stall_pub.publish(
                PointCloud(Header(t, self.base_frame), pts)), c.rotation_center_x)
        node.subscribe("move_base_simple/goal", PoseStamped, callback=self._on_goal, mode="queue")
        node.subscribe("move_base/goal", MoveBaseGoal, mode="queue", callback=self._on_goal_with_id)
        node.service("move_base/send_goal", self._send_goal_service, MoveBaseGoal)
        node.service("move_base/cancel_goal", self._cancel_service)
        self._cancel_sub = None
        self._cancel_sub = node.subscribe("move_base/cancel", None, mode="queue", callback=lambda _m: self.cancel(
            self._cancel_sub.last_publisher if self._cancel_sub is not None else ""))
        node.service("make_plan", self.planning.make_plan_service, PlanRequest)
        for n in c.notes:
            node.log.debug("no effect: %s", n)
        self.timer = node.timer(1.0 / p.controller_frequency, self.cycle, on_data=p.control_on_costmap)

    @property
    def global_frame(self) -> str | None:
        """The global costmap's frame: configured, else that of its messages (None until one arrives)."""
        return self.planning.global_frame

    @property
    def result(self) -> PlanResult:
        """The last global plan's result (an empty one since the current goal came in)."""
        return self.planning.result

    # -- inputs ------------------------------------------------------------------------------------
    def _on_goal_with_id(self, g: MoveBaseGoal) -> None:
        with self.intake_lock:
            if g.goal_id and self._answer(g.goal_id) is not None:
                self.node.log.debug("goal %s again: already taken in", g.goal_id)
                return
            self._on_goal(g.target_pose, g.goal_id)

    def _send_goal_service(self, g: MoveBaseGoal) -> MoveBaseStatus:
        if not g.goal_id:
            raise ValueError("move_base/send_goal needs a goal_id (a resent goal is known by it)")
        with self.intake_lock:  # two deliveries of one goal at once: the second finds the first's answer
            if self._answer(g.goal_id) is None:
                self._on_goal(g.target_pose, g.goal_id)
            return self._answer(g.goal_id)

    def _cancel_service(self, req) -> MoveBaseStatus:
        gid = req.data if isinstance(req, Text) else ""
        with self.lock:
            current = self.machine.goal.goal_id if self.machine.goal else ""
        if not gid or gid == current:  # (cancel takes cmd_lock before self.lock: not called holding it)
            self.cancel(f"a cancel_goal call ({gid or 'any goal'})")
        return self._answer(gid or current) or self._status_msg(GoalStatus.LOST, "no such goal", 0.0, gid)

    def _answer(self, gid: str) -> MoveBaseStatus | None:
        """The state of goal ``gid`` if it was ever taken in (current, finished or rejected), else None."""
        with self.lock:
            m = self.machine
            if m.goal is not None and m.goal.goal_id == gid:
                return self._status_msg(m.status, m.reason, 0.0, gid)
            return self._answers.get(gid)

    def _remember(self, msg: MoveBaseStatus) -> None:
        self._answers[msg.goal_id] = msg
        self._answers.move_to_end(msg.goal_id)
        while len(self._answers) > SEEN_GOALS:
            self._answers.popitem(last=False)

    def _on_goal(self, msg: PoseStamped, goal_id: str = "") -> None:
        gf = self.global_frame
        frame = strip_frame(msg.header.frame_id) or gf
        now = self.node.clock.now()
        try:
            if gf is None:
                raise RuntimeError("no global costmap received yet (its frame is the planning frame)")
            to_global = self.tf.buffer.lookup_pose2d(gf, frame, 0.0, 1.0)
        except Exception as e:  # noqa: BLE001 - any TF problem rejects the goal with the reason
            self._publish_status(GoalStatus.REJECTED, f"goal rejected: no transform {gf} <- {frame}: {e}",
                                 terminal=True, gid=goal_id or "rejected")
            return
        goal = to_global.compose(msg.pose.to_pose2d())
        with self.lock:
            gid = goal_id or f"goal-{next(self.ids)}"
            old = self.machine.goal
            if old is not None and old.goal_id != gid and self.machine.state is not State.IDLE:
                self._remember(self._status_msg(GoalStatus.PREEMPTED, f"replaced by goal {gid}", 0.0, old.goal_id))
            self.goal_msg = PoseStamped(Header(now, gf), goal.to_transform())
            self.planning.result = PlanResult()
            self.machine.set_goal(gid, goal, now)
        self.goal_pub.publish(self.goal_msg)
        self.node.log.info("new goal %s: (%.2f, %.2f, %.2f) in %s (given in %s)", gid, goal.x, goal.y,
                           goal.theta, gf, frame)

    def _on_local_costmap(self, _msg: Costmap) -> None:
        timer = getattr(self, "timer", None)  # a costmap may come in before the timer exists
        if timer is not None:
            timer.kick()  # control_on_costmap: a cycle now; a fixed-rate timer ignores it

    def cancel(self, by: str = "") -> None:
        """Stop and end the goal (PREEMPTED); ``by``: the node that published the cancel, for the log."""
        # Stop first: the control cycle may hold self.lock for a while (a recovery's costmap-clear
        # service calls run inside it), and cancel must zero cmd_vel at once. Until the state machine has
        # taken the cancel in (below, under self.lock), no cycle publishes (it checks under cmd_lock): a
        # cycle that ticked the machine before the cancel reached it would send the goal's command after
        # this zero (seen: the rotate recovery's 1 rad/s).
        with self.cmd_lock:
            self._cancelling += 1
            self.cmd.publish(Twist())
        try:
            with self.lock:
                goal = self.machine.goal
                if goal is not None:
                    self.node.log.info("goal %s cancelled by %s", goal.goal_id, by or "an unnamed publisher")
                self.machine.cancel(self.node.clock.now(), by)
                self.cmd.publish(Twist())
                self._report(None)
        finally:
            with self.cmd_lock:
                self._cancelling -= 1

    # -- collaborators -------------------------------------------------------------------------------
    def _clear_costmaps(self, reset_distance: float, which: str = "both") -> None:
        names = {"both": ("local_costmap", "global_costmap"), "local": ("local_costmap",),
                 "global": ("global_costmap",)}[which]
        for name in names:
            try:
                self.node.call(f"{name}/clear", Scalar(value=reset_distance), timeout=1.0)
            except Exception as e:  # noqa: BLE001 - recovery goes on without it
                self.node.log.warning("could not clear %s: %s", name, e)

    def _stalled_on(self) -> tuple[float, float] | None:
        """The (v, w) the robot stalled on, while a stall's recoveries run (the escape moves against it)."""
        m = self.machine
        if m.trigger is not Trigger.STALL or m.stall_command is None:
            return None
        return m.stall_command[0], m.stall_command[2]

    def _local_view(self):
        """(local grid, resolution, origin, robot pose in the local frame), or None (an escape's view)."""
        costmap, pose = self.controller.costmap, self.controller.local_pose
        return None if costmap is None or pose is None else (*costmap, pose)

    def _blocked(self, pose_global: Pose2D, yaws: np.ndarray) -> bool:
        """Would the footprint touch a lethal cell at any of these headings (here, on the local costmap)?"""
        lp, g = self.controller.local_pose, self._pose_global
        if lp is None or g is None:
            return True
        offset = lp.theta - g.theta
        return any(self.controller.footprint_blocked(Pose2D(lp.x, lp.y, y + offset)) for y in np.asarray(yaws))

    # -- the control cycle ---------------------------------------------------------------------------
    def _robot_pose(self, now: float):
        """(global pose, local pose, local_from_global, problem)."""
        return robot_pose(self.tf.buffer, self.global_frame, self.local_frame, self.base_frame,
                          self.config.transform_tolerance, now)

    def cycle(self) -> None:
        t0 = time.perf_counter()
        now = self.node.clock.now()
        pose, local_pose, lfg, problem = self._robot_pose(now)
        self._pose_global = pose
        odom = self.odom.latest()
        vel = (odom.twist.linear.x, odom.twist.linear.y, odom.twist.angular.z) if odom else (0.0, 0.0, 0.0)
        cm = self.local_costmap.latest()
        costmap = None if cm is None else (cm.data, cm.resolution, (cm.origin.x, cm.origin.y))
        self._blind = blind = self.health.problem(time.monotonic(), SENSORS_MAX_AGE)
        with self.lock:
            if local_pose is not None:
                self.controller.update(local_pose, lfg, costmap)
            d = self.machine.tick(now, pose, vel, problem, blocked=blind and f"sensor data: {blind}")
            if self.machine.state is not State.IDLE or d.event:
                with self.cmd_lock:
                    if not self._cancelling:  # else a cancel is under way: stay stopped
                        self.cmd.publish(Twist.planar(d.cmd[0], d.cmd[2], d.cmd[1]))
                        self.trace_pub.publish(Scalar(Header(now, ""), -1.0 if cm is None else cm.header.stamp))
            if d.event:
                self._log_event(d.event, now)
            if self.stall_marker is not None:
                self.stall_marker.tick(now, self.machine.stalls, self.machine.stall_command)
            self._report(pose)
        last = self.controller.last
        if self.machine.state is State.CONTROLLING and last is not None and last.trajectory is not None:
            traj = np.asarray(last.trajectory, float).reshape(-1, 3)
            self.lplan_pub.publish(Path(Header(now, self.local_frame), traj))
        self.loop_pub.publish(Scalar(Header(now, ""), time.perf_counter() - t0))

    def _log_event(self, event: str, now: float) -> None:
        """State changes to the log; the same change again within 2 s (a cycle that keeps going back to
        PLANNING) is counted and said once with its count."""
        last, since, count = self._last_event
        if event == last and now - since < 2.0:
            self._last_event = (last, since, count + 1)
            return
        if count:
            self.node.log.info("(the last state change happened %d more times)", count)
        self.node.log.info("%s", event)
        self._last_event = (event, now, 0)

    def _report(self, pose: Pose2D | None) -> None:
        m = self.machine
        dist = 0.0
        if pose is not None and m.goal is not None:
            dist = pose.distance(m.goal.pose)
        terminal = m.state is State.IDLE and m.status in TERMINAL
        reason = m.reason
        if self._blind and m.state is State.IDLE:  # say it before a goal comes in too
            reason = f"{reason}; sensor data: {self._blind}"
        override = safety_override(self.safety)
        if override and m.state is not State.IDLE:
            reason = f"{reason}; {override}" if reason else override
        if reason.startswith("no progress"):  # a collision since (just before) the robot stopped progressing
            now = self.node.clock.now()
            if hit := collision_hint(self.collision, now, max(120.0, m.stalled_for(now) + 10.0)):
                reason = f"{reason}; {hit}"
        if m.state is not State.IDLE and not self.cmd.matching:  # a route watched, not trusted
            reason = f"{reason}; {NO_CMD_ROUTE}" if reason else NO_CMD_ROUTE
        self._publish_status(m.status, reason, terminal, dist)

    def _status_msg(self, status: int, reason: str, dist: float, gid: str | None = None) -> MoveBaseStatus:
        m = self.machine
        now = self.node.clock.now()
        frame = self.global_frame or ""
        if gid is None:
            gid = m.goal.goal_id if m.goal else ""
        used = self.result.goal_used
        return MoveBaseStatus(Header(now, frame), gid, status, m.state.value, reason,
                              self.goal_msg or PoseStamped(),
                              PoseStamped(Header(now, frame), used.to_transform()),
                              self.result.goal_offset_m, dist, m.recovery_index)

    def _publish_status(self, status: int, reason: str, terminal: bool, dist: float = 0.0,
                        gid: str | None = None) -> None:
        msg = self._status_msg(status, reason, dist, gid)
        self.status_pub.publish(msg)
        if terminal:
            with self.lock:
                self._remember(msg)
            if self._last_terminal != (msg.goal_id, status):
                self._last_terminal = (msg.goal_id, status)
                self.result_pub.publish(msg)

    def close(self) -> None:
        self.timer.cancel()
        self.planner.close()
        self.planning.close()
        self.cmd.publish(Twist())
        self.tf.close()


def warm_before_fork() -> None:
    """(common.fork_server) The planners' compiled kernels, loaded once for every move_base forked after."""
    from master_side.planning.warmup import warm_navfn

    warm_navfn()
    warm_local_planners()


def start(node: Node, cfg: dict, source: str) -> MoveBaseNode:
    # The bus's receiving threads share the GIL with the control cycle: hand it over every 1 ms
    # instead of Python's 5 ms, so decoding a costmap delays a cycle by little.
    sys.setswitchinterval(0.001)
    return MoveBaseNode(node, cfg or {}, source)


if __name__ == "__main__":
    from common.runner import node_main

    node_main("move_base", start)

