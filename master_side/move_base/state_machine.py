"""move_base as an explicit state machine (pure: no bus, no clock of its own), following move_base.cpp.

States: IDLE → PLANNING → CONTROLLING → (CLEARING → PLANNING …) → IDLE with a terminal status
(SUCCEEDED, ABORTED, PREEMPTED). The node calls ``tick(now, pose, velocity)`` at
controller_frequency and publishes the returned command; ``reason`` always says, in one line, why
the robot is not moving towards an active goal (empty while it makes progress).

As in ROS: the global planner runs on its own (``planner_thread``): while PLANNING the machine waits
for it (zero velocity), a plan moves it to CONTROLLING, failures past ``planner_patience`` (or
``max_planning_retries``) start a recovery; while CONTROLLING the planner keeps replanning at
``planner_frequency`` and each new plan goes to the controller. A cycle without a valid command goes
back to PLANNING, or, once ``controller_patience`` has passed since the last valid command, to a
recovery. Moving ``oscillation_distance`` resets the ``oscillation_timeout`` clock. The recovery index
goes back to 0 when the condition that triggered the recovery clears (a plan, a valid command, progress).

zenav's addition (``max_in_place_rotation``): valid commands that only turn the robot in place for a
full revolution without it getting anywhere count as a failed controller (recovery), so a local
planner that prefers spinning to entering a tight gap cannot spin until the goal's timeout.
And (``stall_timeout``): valid commands that should have moved the robot but got it nowhere start the
recoveries (trigger ``stall``; ``stall_command`` is the command that stalled, for an escape to move
against): a wall the sensors never showed holds the robot, and the local planner, its costmap clear
there, would push on into it (office02: 35 contacts in 32 s at one place, 2026-11-29).

Collaborators, supplied by the node: a ``GlobalPlanner``, a ``Controller`` and ``Recovery`` behaviours
(the Protocols of ``contracts.py``); a plain planning function goes in through
``planner_thread.ImmediatePlanner(fn, planner_frequency)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from common.geometry import Pose2D, TurnCounter, normalize_angle
from common.messages import GoalStatus
from master_side.move_base.contracts import Controller, GlobalPlanner, Recovery
from master_side.move_base.machine_types import NO_PLAN, ControlResult, Decision, Goal, State, Trigger
from master_side.move_base.params import MoveBaseParams
from master_side.planning.local.base import velocity3

__all__ = ["MoveBaseMachine", "State", "Trigger", "ControlResult", "Decision"]


ZERO = (0.0, 0.0, 0.0)
IN_PLACE = 0.01  # m/s: a command slower than this turns the robot in place
PROGRESS_M, PROGRESS_RAD = 0.05, 0.2  # moving or turning this much is progress (no_progress_report)
STALL_COMMANDED = 2.0  # stall_timeout: commanded motion (in progress units: 0.1 m or 0.4 rad) before a stall


def _progress(a: Pose2D, b: Pose2D) -> float:
    """a to b in units of progress: 1 = PROGRESS_M moved, or PROGRESS_RAD turned, or a mix."""
    return a.distance(b) / PROGRESS_M + abs(normalize_angle(b.theta - a.theta)) / PROGRESS_RAD


@dataclass
class MoveBaseMachine:
    params: MoveBaseParams
    planner: GlobalPlanner
    controller: Controller
    recoveries: list[Recovery] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.state = State.IDLE
        self.status = GoalStatus.PENDING
        self.goal: Goal | None = None
        self.reason = "no goal"
        self.recovery_index = 0
        self.trigger: Trigger | None = None
        self._recovery: Recovery | None = None
        self._recovery_started = False  # its start() runs on the first CLEARING tick, with that tick's time
        self._pending_event = ""
        self.stall_command: tuple[float, float, float] | None = None  # the command of the last stall
        self.stalls = 0  # stalls so far (a new one: the node marks where it pushed, stall_marks)
        self._reset_clocks(0.0, None)

    def _reset_clocks(self, now: float, pose: Pose2D | None) -> None:
        self._last_valid_plan = self._last_valid_control = self._osc_time = self._prog_time = now
        self._osc_pose = self._prog_pose = pose
        self._retries = 0
        self._spin = TurnCounter()  # in-place turning while commanding no translation
        self._stall_ref: Pose2D | None = pose  # stall_timeout: from where, since when, how much commanded
        self._stall_time = self._last_tick = now
        self._stall_commanded = 0.0

    # -- goal management -----------------------------------------------------------------------
    def set_goal(self, goal_id: str, goal: Pose2D, now: float) -> None:
        """A new goal (already in the global frame) preempts any current one."""
        self.goal = Goal(goal_id, goal)
        self.status = GoalStatus.ACTIVE
        self.recovery_index, self.trigger, self._recovery = 0, None, None
        self._reset_clocks(now, None)
        self.planner.start(goal)
        self._enter(State.PLANNING, f"new goal {goal_id} at ({goal.x:.2f}, {goal.y:.2f}, {goal.theta:.2f})")
        self.reason = "waiting for a global plan"

    def cancel(self, now: float, by: str = "") -> Decision:
        """Cancel from any state: zero velocity now, status PREEMPTED. ``by``: who asked (in the reason)."""
        if self.goal is not None and self.state is not State.IDLE:
            self.status = GoalStatus.PREEMPTED
            self._finish(f"goal cancelled by {by}" if by else "goal cancelled")
        return self._decide(ZERO)

    # -- one control cycle ---------------------------------------------------------------------
    def tick(self, now: float, pose: Pose2D | None, velocity: tuple[float, float, float],
             pose_problem: str = "", blocked: str = "") -> Decision:
        """One cycle. ``blocked``: a reason the base must not move this cycle (stale sensor data); it
        stops the robot like ROS's "sensor data is out of date" without consuming patience."""
        dt, self._last_tick = min(max(now - self._last_tick, 0.0), 0.5), now  # the cycle a command lasts
        if self.state is State.IDLE or self.goal is None:
            return self._decide(ZERO)
        if pose is None:
            # Cannot localise (stale or missing TF): stop and say why; do not run out of patience.
            self.reason = pose_problem or "robot pose unknown"
            return self._decide(ZERO)
        p = self.params
        if self._osc_pose is None or pose.distance(self._osc_pose) >= p.oscillation_distance:
            self._osc_pose, self._osc_time = pose, now
            if self.trigger is Trigger.OSCILLATION:
                self.recovery_index = 0
        if self._prog_pose is None or self.state is not State.CONTROLLING or _progress(self._prog_pose, pose) >= 1:
            self._prog_pose, self._prog_time = pose, now
        if blocked:
            self.reason = blocked
            return self._decide(ZERO)
        new_plan = self._take_plan(now, pose)
        if self.state is State.IDLE:  # planning failed past patience with no recovery left: aborted
            return self._decide(ZERO)
        if self.state is State.CLEARING:
            return self._tick_clearing(now, pose, velocity)
        if self.state is State.PLANNING:
            self.planner.wake()
            return self._decide(ZERO, new_plan)
        return self._tick_controlling(now, pose, velocity, new_plan, dt)

    def _take_plan(self, now: float, pose: Pose2D) -> np.ndarray | None:
        out = self.planner.poll(now, pose)
        p = self.params
        if out.path is not None:
            self.goal.path, self.goal.used = out.path, out.goal_used
            self.controller.set_plan(out.path)
            self._last_valid_plan, self._retries = now, 0
            if self.trigger is Trigger.PLANNING:
                self.recovery_index = 0
            if self.state is State.PLANNING:
                self._enter(State.CONTROLLING, f"plan found ({len(out.path)} poses)")
                self.reason = ""
            return out.path
        if out.failures and self.state is State.PLANNING:
            self._retries += out.failures
            waited = now - self._last_valid_plan
            self.reason = f"no plan: {out.error} (for {waited:.1f} s, planner_patience {p.planner_patience:.1f} s)"
            if waited > p.planner_patience or 0 <= p.max_planning_retries < self._retries:
                self.planner.stop()
                self._start_recovery(Trigger.PLANNING, f"{NO_PLAN} {waited:.1f} s: {out.error}")
        elif out.failures:  # replanning failed while controlling: keep following the old plan
            self.reason = f"replanning failed ({out.error}); following the previous plan"
        return None

    def _tick_controlling(self, now: float, pose: Pose2D, velocity, new_plan, dt: float) -> Decision:
        p = self.params
        if self.controller.goal_reached(pose, velocity):
            self.status = GoalStatus.SUCCEEDED
            self._finish("goal reached")
            return self._decide(ZERO, new_plan)
        cmd = ZERO
        if p.oscillation_timeout > 0 and now - self._osc_time > p.oscillation_timeout:
            self._start_recovery(Trigger.OSCILLATION, f"oscillating: moved < {p.oscillation_distance} m in "
                                                      f"{p.oscillation_timeout:.1f} s")
        res = self.controller.compute(pose, velocity)
        spin = self._spun(pose, res.cmd) if res.ok else ""
        stall = self._stalled(now, pose, res.cmd, dt) if res.ok and not spin and self.state is State.CONTROLLING \
            else ""
        if stall:
            self.note_stall(res.cmd)
            self._start_recovery(Trigger.STALL, stall)
            return self._decide(ZERO, new_plan)
        if res.ok and not spin:
            self._last_valid_control = now
            if self.trigger is Trigger.CONTROLLING:
                self.recovery_index = 0
            if self.state is State.CONTROLLING:
                self.reason = self._no_progress(now, pose, res.cmd)
                cmd = velocity3(res.cmd)
            return self._decide(cmd, new_plan)
        if self.state is not State.CONTROLLING:  # the oscillation check started a recovery
            return self._decide(ZERO, new_plan)
        if spin:
            self._start_recovery(Trigger.CONTROLLING, spin)
            return self._decide(ZERO, new_plan)
        waited = now - self._last_valid_control
        self.reason = f"no valid command: {res.reason} (for {waited:.1f} s, controller_patience " \
                      f"{p.controller_patience:.1f} s)"
        if waited > p.controller_patience:
            self._start_recovery(Trigger.CONTROLLING, f"controller failed for {waited:.1f} s: {res.reason}")
        else:  # ROS: back to planning (the robot stops until a new plan arrives)
            self._last_valid_plan, self._retries = now, 0
            self.planner.start(self.goal.pose)
            self._enter(State.PLANNING, f"no valid command ({res.reason}); replanning")
        return self._decide(ZERO, new_plan)

    def note_stall(self, cmd: tuple[float, float, float]) -> None:
        """A command that got the robot nowhere (the controller's, or a recovery's own move): counted, and kept
        for the node's stall marks and for an escape to move against."""
        self.stall_command, self.stalls = cmd, self.stalls + 1

    def stalled_for(self, now: float) -> float:
        """Seconds since the robot last made progress toward the goal (while controlling)."""
        return now - self._prog_time

    def _no_progress(self, now: float, pose: Pose2D, cmd) -> str:
        """'' or why valid commands got the robot nowhere for ``no_progress_report`` s (ROS is silent)."""
        limit, stalled = self.params.no_progress_report, now - self._prog_time
        if limit <= 0 or stalled < limit:
            return ""
        moved = pose.distance(self._prog_pose)
        turned = abs(normalize_angle(pose.theta - self._prog_pose.theta))
        return (f"no progress for {stalled:.0f} s: moved {moved:.2f} m and turned {turned:.2f} rad while "
                f"commanding v={cmd[0]:.2f} m/s, w={cmd[2]:.2f} rad/s")

    def _stalled(self, now: float, pose: Pose2D, cmd, dt: float) -> str:
        """'' or why the robot stalls: the valid commands since it last made progress were worth
        STALL_COMMANDED of motion and ``stall_timeout`` s have passed (zenav's). ``dt``: since the last
        cycle, the time this command follows the last one's; cycles without a command (the robot stopped)
        neither add nor reset."""
        limit = self.params.stall_timeout
        if limit <= 0:
            return ""
        if self._stall_ref is None or _progress(self._stall_ref, pose) >= 1:
            if self._stall_ref is not None and self.trigger is Trigger.STALL:  # it moves again
                self.recovery_index = 0
            self._stall_ref, self._stall_time, self._stall_commanded = pose, now, 0.0
            return ""
        self._stall_commanded += (abs(cmd[0]) / PROGRESS_M + abs(cmd[2]) / PROGRESS_RAD) * dt
        held = now - self._stall_time
        if held < limit or self._stall_commanded < STALL_COMMANDED:
            return ""
        moved = pose.distance(self._stall_ref)
        turned = abs(normalize_angle(pose.theta - self._stall_ref.theta))
        self._stall_ref = None
        return (f"stalled: commanding v={cmd[0]:.2f} m/s, w={cmd[2]:.2f} rad/s got the robot {moved:.2f} m and "
                f"{turned:.2f} rad in {held:.1f} s: something its sensors do not show holds it")

    def _spun(self, pose: Pose2D, cmd) -> str:
        """'' or why the in-place turning has gone on too long (zenav's max_in_place_rotation)."""
        limit = self.params.max_in_place_rotation
        if limit <= 0 or math.hypot(cmd[0], cmd[1]) >= IN_PLACE:
            self._spin.reset()
            return ""
        if self._spin.add(pose.theta) < limit:
            return ""
        self._spin.reset()
        return f"turned {limit:.1f} rad in place without moving (the local planner finds nothing better)"

    def _start_recovery(self, trigger: Trigger, why: str) -> None:
        enabled = [r for r in self.recoveries if r.enabled(self.params)]
        if not self.params.recovery_behavior_enabled:
            enabled = []
        self.trigger = trigger
        if self.recovery_index >= len(enabled):
            self.planner.stop()
            self.status = GoalStatus.ABORTED
            tried = f"after {self.recovery_index} recoveries" if enabled else "recovery disabled"
            self._finish(f"aborted: {why} ({tried})")
            return
        self._recovery = enabled[self.recovery_index]
        self.recovery_index += 1
        self._recovery_started = False
        self._enter(State.CLEARING, f"recovery {self.recovery_index}/{len(enabled)} "
                                    f"({self._recovery.name}) because {why}")
        self.reason = f"recovery {self.recovery_index}/{len(enabled)}: {self._recovery.name} ({why})"

    def _tick_clearing(self, now: float, pose: Pose2D, velocity) -> Decision:
        r = self._recovery
        if not self._recovery_started:
            self._recovery_started = True
            r.start(now)
        cmd, done = r.step(now, pose, velocity)
        if done:
            self._recovery = None
            self._osc_time, self._last_valid_plan, self._retries = now, now, 0
            self._spin.reset()
            self._stall_ref = None
            self.planner.start(self.goal.pose)
            self._enter(State.PLANNING, "recovery done, replanning")
            self.reason = "waiting for a global plan"
            return self._decide(ZERO)
        return self._decide(tuple(cmd))

    # -- helpers -------------------------------------------------------------------------------
    def _finish(self, why: str) -> None:
        self.planner.stop()
        self._enter(State.IDLE, why)
        self.reason = why

    def _enter(self, state: State, event: str) -> None:
        self.state = state
        self._pending_event = f"{state.value}: {event}"

    def _decide(self, cmd, new_plan=None) -> Decision:
        ev, self._pending_event = self._pending_event, ""
        return Decision(cmd, self.state, self.status, self.reason, new_plan, ev)
