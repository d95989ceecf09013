"""move_base state machine transitions, with small scripted planner/controller collaborators."""

from __future__ import annotations

import numpy as np
import pytest

from common.geometry import Pose2D
from common.messages import GoalStatus
from master_side.move_base.params import MoveBaseParams
from master_side.move_base.planner_thread import ImmediatePlanner
from master_side.move_base.recovery import ClearCostmapRecovery, RotateRecovery, default_recoveries
from master_side.move_base.state_machine import ControlResult, MoveBaseMachine, State


class ScriptedPlanner:
    def __init__(self, fail: bool = False):
        self.fail, self.calls = fail, 0

    def __call__(self, start: Pose2D, goal: Pose2D):
        self.calls += 1
        if self.fail:
            raise RuntimeError("NoPath: goal unreachable")
        return np.array([[start.x, start.y, 0.0], [goal.x, goal.y, goal.theta]]), goal


class ScriptedController:
    def __init__(self, ok: bool = True, reached_after: int = 10**9):
        self.ok, self.reached_after, self.n, self.plan = ok, reached_after, 0, None

    def set_plan(self, path):
        self.plan = path

    def compute(self, pose, vel):
        self.n += 1
        if self.ok:
            return ControlResult((0.3, 0.0, 0.1), True)
        return ControlResult(reason="no valid trajectory: obstacle cost rejected 400/400 samples")

    def goal_reached(self, pose, vel):
        return self.n >= self.reached_after


def machine(planner=None, controller=None, recoveries=None, **kw):
    params = MoveBaseParams(**kw)
    return MoveBaseMachine(params, ImmediatePlanner(planner or ScriptedPlanner(), params.planner_frequency),
                           controller or ScriptedController(),
                           recoveries if recoveries is not None else [])


def test_idle_without_goal_commands_zero():
    m = machine()
    d = m.tick(0.0, Pose2D(), (0, 0, 0))
    assert d.cmd == (0.0, 0.0, 0.0) and d.state is State.IDLE


def test_goal_goes_planning_then_controlling_then_succeeds():
    m = machine(controller=ScriptedController(reached_after=2))
    m.set_goal("g1", Pose2D(2, 0, 0), 0.0)
    assert m.state is State.PLANNING
    d = m.tick(0.1, Pose2D(), (0, 0, 0))
    assert d.state is State.CONTROLLING and d.cmd == (0.3, 0.0, 0.1) and d.new_plan is not None
    assert d.reason == ""
    m.tick(0.2, Pose2D(0.1, 0, 0), (0.3, 0, 0))
    d = m.tick(0.3, Pose2D(0.2, 0, 0), (0.3, 0, 0))
    assert d.state is State.IDLE and d.status == GoalStatus.SUCCEEDED and d.cmd == (0.0, 0.0, 0.0)


def test_planner_failure_past_patience_without_recoveries_aborts_with_reason():
    m = machine(planner=ScriptedPlanner(fail=True), planner_patience=1.0)
    m.set_goal("g", Pose2D(5, 5, 0), 0.0)
    d = m.tick(0.1, Pose2D(), (0, 0, 0))
    assert d.state is State.PLANNING and "no plan" in d.reason and d.cmd == (0.0, 0.0, 0.0)
    d = m.tick(1.5, Pose2D(), (0, 0, 0))
    assert d.state is State.IDLE and d.status == GoalStatus.ABORTED
    assert "unreachable" in d.reason


def test_controller_failure_runs_recoveries_in_order_then_aborts():
    cleared = []
    recs = [ClearCostmapRecovery(cleared.append, 3.0, "conservative reset"),
            ClearCostmapRecovery(cleared.append, 0.0, "aggressive reset")]
    m = machine(controller=ScriptedController(ok=False), recoveries=recs, controller_patience=0.5)
    m.set_goal("g", Pose2D(2, 0, 0), 0.0)
    m.tick(0.0, Pose2D(), (0, 0, 0))
    d = m.tick(0.2, Pose2D(), (0, 0, 0))
    assert "no valid command" in d.reason and "obstacle" in d.reason and d.cmd == (0.0, 0.0, 0.0)
    states = []
    t = 0.2
    while m.state is not State.IDLE and t < 20:
        t += 0.1
        d = m.tick(t, Pose2D(), (0, 0, 0))
        states.append(d.state)
    assert cleared == [3.0, 0.0]
    assert State.CLEARING in states
    assert d.status == GoalStatus.ABORTED and "after 2 recoveries" in d.reason


def test_rotate_recovery_is_skipped_when_clearing_rotation_not_allowed():
    p = MoveBaseParams(clearing_rotation_allowed=False)
    recs = default_recoveries(p, lambda d: None)
    assert [r.name for r in recs if r.enabled(p)] == ["conservative reset", "aggressive reset"]


def test_rotate_recovery_turns_one_revolution_then_finishes():
    r = RotateRecovery(1.0)
    r.start(0.0)
    yaw, t = 0.0, 0.0
    done = False
    while not done and t < 20:
        cmd, done = r.step(t, Pose2D(0, 0, yaw), (0, 0, 1.0))
        yaw += cmd[2] * 0.1
        t += 0.1
    assert done and 6.0 < t < 7.5


def test_cancel_from_recovery_stops_immediately():
    m = machine(controller=ScriptedController(ok=False), controller_patience=0.0,
                recoveries=[RotateRecovery(0.5)])
    m.set_goal("g", Pose2D(2, 0, 0), 0.0)
    m.tick(0.0, Pose2D(), (0, 0, 0))
    d = m.tick(0.1, Pose2D(), (0, 0, 0))
    d = m.tick(0.2, Pose2D(), (0, 0, 0))
    assert m.state is State.CLEARING and d.cmd[2] == pytest.approx(0.5)
    d = m.cancel(0.25, by="zenav_goal")
    assert d.cmd == (0.0, 0.0, 0.0) and d.status == GoalStatus.PREEMPTED and d.state is State.IDLE
    assert d.reason == "goal cancelled by zenav_goal"  # who cancelled it, in the status line
    assert m.tick(0.3, Pose2D(), (0, 0, 0)).cmd == (0.0, 0.0, 0.0)


def test_unknown_pose_stops_and_explains_without_consuming_patience():
    m = machine(controller=ScriptedController(), controller_patience=0.1)
    m.set_goal("g", Pose2D(2, 0, 0), 0.0)
    d = m.tick(0.5, None, (0, 0, 0), pose_problem="stale TF: odom->base_link is 1.4 s old (tolerance 0.5 s)")
    assert d.cmd == (0.0, 0.0, 0.0) and "stale TF" in d.reason and d.state is State.PLANNING


def test_new_goal_preempts_current_one():
    m = machine()
    m.set_goal("a", Pose2D(1, 0, 0), 0.0)
    m.tick(0.1, Pose2D(), (0, 0, 0))
    m.set_goal("b", Pose2D(3, 0, 0), 0.2)
    assert m.goal.goal_id == "b" and m.state is State.PLANNING


def test_oscillation_timeout_triggers_recovery():
    cleared = []
    m = machine(recoveries=[ClearCostmapRecovery(cleared.append, 3.0)], oscillation_timeout=1.0,
                oscillation_distance=0.5)
    m.set_goal("g", Pose2D(5, 0, 0), 0.0)
    t = 0.0
    while not cleared and t < 5:
        m.tick(t, Pose2D(0.01, 0, 0), (0, 0, 0))
        t += 0.1
    assert cleared and 1.0 < t < 1.5


def test_planning_failure_after_the_last_recovery_aborts_even_with_an_old_plan_in_the_controller():
    """A goal reached earlier leaves its plan in the controller; an unreachable next goal must abort, not
    'succeed' on that old plan."""
    ctl = ScriptedController(reached_after=0)  # the robot stands at the previous goal
    recs = [ClearCostmapRecovery(lambda d: None, 3.0)]
    m = machine(controller=ctl, recoveries=recs, planner_patience=0.5)
    m.set_goal("a", Pose2D(1, 0, 0), 0.0)
    assert m.tick(0.1, Pose2D(1, 0, 0), (0, 0, 0)).status == GoalStatus.SUCCEEDED
    m.planner.plan = ScriptedPlanner(fail=True)
    m.set_goal("b", Pose2D(10, 10, 0), 0.2)
    t, d = 0.2, None
    while m.state is not State.IDLE and t < 10:
        t += 0.1
        d = m.tick(t, Pose2D(1, 0, 0), (0, 0, 0))
    assert d.status == GoalStatus.ABORTED and "unreachable" in d.reason


def test_a_robot_held_in_place_while_controlling_gets_a_no_progress_reason_and_keeps_its_goal():
    """ROS stays silent while the local planner's commands get the robot nowhere (oscillation_timeout
    0): zenav keeps controlling, as ROS does, but the status says so after no_progress_report."""
    m = machine(no_progress_report=3.0)
    m.set_goal("g", Pose2D(5, 0, 0), 0.0)
    t, reasons = 0.0, []
    while t < 6.0:
        t = round(t + 0.05, 6)
        d = m.tick(t, Pose2D(0.01, 0.0, 0.0), (0.0, 0.0, 0.0))  # commanded (0.3, 0.1), held in place
        reasons.append((t, d.reason))
    assert d.state is State.CONTROLLING and d.cmd == (0.3, 0.0, 0.1)
    first = next(t for t, r in reasons if r)
    assert 3.0 <= first <= 3.2
    assert reasons[-1][1].startswith("no progress for 6 s: moved 0.00 m and turned 0.00 rad while commanding "
                                     "v=0.30 m/s, w=0.10 rad/s")
    assert m.stalled_for(t) == pytest.approx(6.0, abs=0.1)  # how far back a collision still explains it
    d = m.tick(t + 0.05, Pose2D(0.2, 0.0, 0.0), (0.3, 0.0, 0.0))  # it moves again: the reason clears
    assert d.reason == ""


def test_the_collision_that_stopped_the_robot_is_named_however_long_ago():
    """The hint names the robot's last collision when it came since (or just before) the robot stopped
    progressing: a robot wedged for ten minutes was hit ten minutes ago (issue 32)."""
    from common.messages import Collision, Header
    from master_side.move_base.robot_inputs import collision_hint

    class Latest:  # what the node's subscription hands the hint: its latest message
        def __init__(self, msg):
            self.msg = msg

        def latest(self):
            return self.msg

    hit = Latest(Collision(Header(100.0, "map"), 1, -9.40, 4.31))
    assert collision_hint(hit, 860.0) == ""  # 760 s ago: beyond the default 120 s
    assert collision_hint(hit, 860.0, within=758.0 + 10.0) == "collision #1 at (-9.40, 4.31) in map 760 s ago"
    assert collision_hint(Latest(None), 860.0, within=1e9) == ""


def test_slow_progress_is_progress():
    m = machine(no_progress_report=3.0)
    m.set_goal("g", Pose2D(5, 0, 0), 0.0)
    t = 0.0
    while t < 10.0:  # 2 cm/s forward, then turning 0.1 rad/s in place: never 'no progress'
        t = round(t + 0.05, 6)
        pose = Pose2D(0.02 * min(t, 5.0), 0.0, 0.1 * max(0.0, t - 5.0))
        assert m.tick(t, pose, (0.02, 0.0, 0.0)).reason == ""


def test_commands_that_get_the_robot_nowhere_for_stall_timeout_start_the_recoveries_as_a_stall():
    """zenav's stall_timeout: valid commands, the robot held in place (a wall no sensor shows): after the
    timeout the recoveries start, the machine keeps the stalled command for an escape; without progress the
    next stall goes on to the next recovery, and after the last the goal is aborted, saying why."""
    from master_side.move_base.state_machine import Trigger

    cleared: list[float] = []
    recs = [ClearCostmapRecovery(cleared.append, 3.0, "first"), ClearCostmapRecovery(cleared.append, 1.0, "second")]
    m = machine(recoveries=recs, stall_timeout=2.0)
    m.set_goal("g", Pose2D(5, 0, 0), 0.0)
    t, events = 0.0, []
    while m.state is not State.IDLE and t < 30.0:
        t = round(t + 0.05, 6)
        d = m.tick(t, Pose2D(0.01, 0.0, 0.0), (0.0, 0.0, 0.0))  # commanded (0.3, 0.1), held in place
        if d.event:
            events.append((t, d.event))
    stalls = [(t, e) for t, e in events if "because stalled" in e]
    assert len(stalls) == 2 and 2.0 <= stalls[0][0] <= 2.2, events
    assert "recovery 1/2 (first) because stalled: commanding v=0.30 m/s, w=0.10 rad/s got the robot 0.00 m" \
        in stalls[0][1]
    assert m.trigger is Trigger.STALL and m.stall_command == (0.3, 0.0, 0.1) and cleared == [3.0, 1.0]
    assert m.stalls == 3  # two started a recovery, the third aborted; a node marks each new one (stall_marks)
    assert d.status == GoalStatus.ABORTED and "stalled" in d.reason and "after 2 recoveries" in d.reason


def test_a_robot_that_moves_slowly_or_turns_as_commanded_does_not_stall():
    class Slow(ScriptedController):
        def compute(self, pose, vel):  # 2 cm/s for 5 s, then a slow turn in place
            return ControlResult((0.02, 0.0, 0.0) if pose.x < 0.099 else (0.0, 0.0, 0.1), True)

    m = machine(controller=Slow(), recoveries=[ClearCostmapRecovery(lambda d: None, 3.0)], stall_timeout=1.0)
    m.set_goal("g", Pose2D(5, 0, 0), 0.0)
    t = 0.0
    while t < 10.0:
        t = round(t + 0.05, 6)
        pose = Pose2D(0.02 * min(t, 5.0), 0.0, 0.1 * max(0.0, t - 5.0))
        assert m.tick(t, pose, (0.02, 0.0, 0.0)).state is State.CONTROLLING, t


def test_a_command_now_and_then_counts_for_its_own_cycles_only():
    """Valid commands on one cycle in four (replans between, the robot stopped meanwhile): the robot covers
    what those cycles commanded, so it is not stalled (a command counted until the next valid one made
    0.04 m in 1 s look like a stall in the mall)."""
    class Sometimes(ScriptedController):
        def compute(self, pose, vel):
            self.n += 1
            return ControlResult((0.1, 0.0, 0.0), True) if self.n % 4 == 0 else ControlResult(reason="no trajectory")

    m = machine(controller=Sometimes(), recoveries=[ClearCostmapRecovery(lambda d: None, 3.0)], stall_timeout=1.0,
                controller_patience=30.0)
    m.set_goal("g", Pose2D(5, 0, 0), 0.0)
    t, x = 0.0, 0.0
    while t < 6.0:
        t = round(t + 0.05, 6)
        d = m.tick(t, Pose2D(x, 0.0, 0.0), (0.0, 0.0, 0.0))
        assert d.state is not State.CLEARING, (t, d.reason)
        x += d.cmd[0] * 0.05  # the robot does what this cycle commands
