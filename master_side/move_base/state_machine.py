"""move_base as an explicit state machine (pure: no bus, no clock of its own).

States: IDLE → PLANNING → CONTROLLING → (CLEARING → PLANNING …) → IDLE with a terminal status
(SUCCEEDED, ABORTED, PREEMPTED). The node calls ``tick(now, pose, velocity)`` at
controller_frequency and publishes the returned command; ``reason`` always says, in one line, why
the robot is not moving towards an active goal (empty while it makes progress).

Collaborators are small protocols, supplied by the node:
  planner(start: Pose2D, goal: Pose2D) -> (path (N,3), goal_used: Pose2D)   raises PlannerError-like
  controller.set_plan(path); controller.compute(pose, velocity) -> ControlResult;
  controller.goal_reached(pose, velocity) -> bool
  recoveries: list of RecoveryBehavior (see recovery.py)
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field

import numpy as np

from common.geometry import Pose2D
from common.messages import GoalStatus
from master_side.move_base.params import MoveBaseParams


class State(enum.Enum):
    IDLE = "IDLE"
    PLANNING = "PLANNING"
    CONTROLLING = "CONTROLLING"
    CLEARING = "CLEARING"


@dataclass(frozen=True)
class ControlResult:
    cmd: tuple[float, float, float] = (0.0, 0.0, 0.0)  # vx, vy, wz
    ok: bool = False
    reason: str = ""  # why no command (e.g. "no valid trajectory: obstacle rejected 400/400")
    trajectory: np.ndarray | None = None


@dataclass(frozen=True)
class Decision:
    """What the node should do after one tick."""

    cmd: tuple[float, float, float]
    state: State
    status: int  # GoalStatus code of the current goal (or of the last one when IDLE)
    reason: str
    new_plan: np.ndarray | None = None  # set when a plan was (re)computed this tick
    event: str = ""  # state-change text for the log ("" if none)


ZERO = (0.0, 0.0, 0.0)


@dataclass
class _Goal:
    goal_id: str
    pose: Pose2D
    used: Pose2D | None = None
    path: np.ndarray | None = None


@dataclass
class MoveBaseMachine:
    params: MoveBaseParams
    planner: object
    controller: object
    recoveries: list = field(default_factory=list)

    def __post_init__(self) -> None:
        self.state = State.IDLE
        self.status = GoalStatus.PENDING
        self.goal: _Goal | None = None
        self.reason = "no goal"
        self.recovery_index = 0
        self._last_plan_time = -math.inf
        self._plan_fail_since: float | None = None
        self._last_valid_control = 0.0
        self._osc_pose: Pose2D | None = None
        self._osc_time = 0.0
        self._recovery = None
        self._plan_failures = 0
        self._pending_event = ""

    # -- goal management -----------------------------------------------------------------------
    def set_goal(self, goal_id: str, goal: Pose2D, now: float) -> None:
        """A new goal (already in the global frame) preempts any current one."""
        self.goal = _Goal(goal_id, goal)
        self.status = GoalStatus.ACTIVE
        self.recovery_index = 0
        self._recovery = None
        self._plan_failures = 0
        self._plan_fail_since = None
        self._enter(State.PLANNING, now, f"new goal {goal_id} at ({goal.x:.2f}, {goal.y:.2f}, {goal.theta:.2f})")
        self._last_plan_time = -math.inf

    def cancel(self, now: float) -> Decision:
        """Cancel from any state: zero velocity now, status PREEMPTED."""
        if self.goal is not None and self.state is not State.IDLE:
            self.status = GoalStatus.PREEMPTED
            self._enter(State.IDLE, now, "goal cancelled")
            self.reason = "goal cancelled"
        return self._decide(ZERO)

    # -- one control cycle ---------------------------------------------------------------------
    def tick(self, now: float, pose: Pose2D | None, velocity: tuple[float, float, float],
             pose_problem: str = "") -> Decision:
        if self.state is State.IDLE or self.goal is None:
            return self._decide(ZERO)
        if pose is None:
            # Cannot localise (stale or missing TF): stop and say why; do not run out of patience.
            self.reason = pose_problem or "robot pose unknown"
            return self._decide(ZERO)
        if self.state is State.CLEARING:
            return self._tick_clearing(now, pose, velocity)
        new_plan = self._maybe_plan(now, pose)
        if self.state is not State.CONTROLLING:
            return self._decide(ZERO, new_plan)
        return self._tick_controlling(now, pose, velocity, new_plan)

    def _maybe_plan(self, now: float, pose: Pose2D) -> np.ndarray | None:
        p = self.params
        due = self.state is State.PLANNING or (
            p.planner_frequency > 0 and now - self._last_plan_time >= 1.0 / p.planner_frequency)
        if not due:
            return None
        self._last_plan_time = now
        try:
            path, used = self.planner(pose, self.goal.pose)
        except Exception as e:  # planner failures are typed exceptions; any error = no plan
            self._plan_failures += 1
            if self._plan_fail_since is None:
                self._plan_fail_since = now
            waited = now - self._plan_fail_since
            # While CONTROLLING the old plan is still followed, as move_base does.
            self.reason = f"no plan: {e} (for {waited:.1f} s, planner_patience {p.planner_patience:.1f} s)"
            over_retries = 0 <= p.max_planning_retries < self._plan_failures
            if waited > p.planner_patience or over_retries:
                self._start_recovery(now, f"no plan for {waited:.1f} s: {e}")
            return None
        self._plan_fail_since = None
        self._plan_failures = 0
        self.goal.path, self.goal.used = path, used
        self.controller.set_plan(path)
        if self.state is State.PLANNING:
            self._last_valid_control = now
            self._osc_pose, self._osc_time = pose, now
            self._enter(State.CONTROLLING, now, f"plan found ({len(path)} poses)")
        return path

    def _tick_controlling(self, now: float, pose: Pose2D, velocity, new_plan) -> Decision:
        p = self.params
        if self.controller.goal_reached(pose, velocity):
            self.status = GoalStatus.SUCCEEDED
            self._enter(State.IDLE, now, "goal reached")
            self.reason = "goal reached"
            return self._decide(ZERO, new_plan)
        # Oscillation / no progress check (oscillation_timeout 0 disables it).
        if self._osc_pose is None or pose.distance(self._osc_pose) >= p.oscillation_distance:
            self._osc_pose, self._osc_time = pose, now
            self.recovery_index = 0 if self._recovery is None else self.recovery_index
        elif p.oscillation_timeout > 0 and now - self._osc_time > p.oscillation_timeout:
            self._start_recovery(now, f"oscillating: moved < {p.oscillation_distance} m in "
                                      f"{p.oscillation_timeout:.1f} s")
            return self._decide(ZERO, new_plan)
        res = self.controller.compute(pose, velocity)
        if res.ok:
            self._last_valid_control = now
            self.reason = ""
            return self._decide(tuple(res.cmd), new_plan)
        waited = now - self._last_valid_control
        self.reason = f"no valid command: {res.reason} (for {waited:.1f} s, controller_patience " \
                      f"{p.controller_patience:.1f} s)"
        if waited > p.controller_patience:
            self._start_recovery(now, f"controller failed for {waited:.1f} s: {res.reason}")
        else:
            self._last_plan_time = -math.inf  # ask for a fresh plan next cycle
        return self._decide(ZERO, new_plan)

    def _start_recovery(self, now: float, why: str) -> None:
        enabled = [r for r in self.recoveries if r.enabled(self.params)]
        if not self.params.recovery_behavior_enabled:
            enabled = []
        if self.recovery_index >= len(enabled):
            self.status = GoalStatus.ABORTED
            tried = f"after {self.recovery_index} recoveries" if enabled else "recovery disabled"
            self._enter(State.IDLE, now, f"aborted: {why} ({tried})")
            self.reason = f"aborted: {why} ({tried})"
            return
        self._recovery = enabled[self.recovery_index]
        self.recovery_index += 1
        self._recovery.start(now)
        self._enter(State.CLEARING, now, f"recovery {self.recovery_index}/{len(enabled)} "
                                          f"({self._recovery.name}) because {why}")
        self.reason = f"recovery {self.recovery_index}/{len(enabled)}: {self._recovery.name} ({why})"

    def _tick_clearing(self, now: float, pose: Pose2D, velocity) -> Decision:
        cmd, done = self._recovery.step(now, pose, velocity)
        if done:
            self._recovery = None
            self._plan_fail_since = None
            self._enter(State.PLANNING, now, "recovery done, replanning")
            self._last_plan_time = -math.inf
            return self._decide(ZERO)
        return self._decide(tuple(cmd))

    # -- helpers -------------------------------------------------------------------------------
    def _enter(self, state: State, now: float, event: str) -> None:
        self.state = state
        self._pending_event = f"{state.value}: {event}"

    def _decide(self, cmd, new_plan=None) -> Decision:
        ev, self._pending_event = self._pending_event, ""
        return Decision(cmd, self.state, self.status, self.reason, new_plan, ev)
