"""Issue 6 acceptance around recovery and goal tolerance, on the room world with the DWA master config
plus two test overrides: ``clearing_rotation_allowed: true`` (so a recovery lasts long enough to cancel in
it: the rotate-in-place recovery) and navfn ``default_tolerance: 0.6`` (so a goal inside the crate is
planned to the nearest reachable point and the result says which)."""

from __future__ import annotations

import math

import pytest

from common.messages import GoalStatus
from testkit.nav_stack import NavStack
from tests.nav_e2e.nav_e2e_checks import (
    CANCEL_LATENCY_S,
    RESULTS,
    XY_TOL,
    cancel_and_measure,
    run_goal,
    send_goal_async,
    status_of,
)
from tests.support import wait_until

SPEED = 2.0


@pytest.fixture(scope="module")
def stack(tmp_path_factory):
    s = NavStack(tmp_path_factory.mktemp("recovery"), "room", "dwa", SPEED,
                 move_base={"clearing_rotation_allowed": True}, navfn={"default_tolerance": 0.6})
    yield s
    s.close()


def test_nav_e2e_goal_inside_the_crate_reports_the_goal_used_and_its_offset(stack):
    before = stack.collision_count()
    run = run_goal(stack, "goal inside the crate", (0.0, 0.0, 0.0))
    st = run.status
    used = st.goal_used.pose.to_pose2d()
    offset = math.hypot(used.x, used.y)
    RESULTS[-1] += f"; goal used ({used.x:.2f}, {used.y:.2f}), goal_offset_m {st.goal_offset_m:.3f}"
    assert run.code == 0, run.line(stack)
    assert st.status == GoalStatus.SUCCEEDED, run.line(stack)
    assert 0.3 < st.goal_offset_m <= 0.6 + 0.05, st.goal_offset_m  # outside the crate, within tolerance
    assert abs(st.goal_offset_m - offset) < 1e-6, (st.goal_offset_m, used)
    truth = run.truth
    assert math.hypot(truth.x - used.x, truth.y - used.y) <= XY_TOL, (truth, used)
    assert stack.collision_count() == before


def test_nav_e2e_cancel_during_the_rotate_recovery_zeroes_cmd_vel_at_once(stack):
    # away from the crate first: the rotate recovery (rightly) does not turn where a corner would hit it
    assert run_goal(stack, "to open space", (-1.5, -1.2, 0.0)).code == 0
    gid = send_goal_async(stack, (10.0, 10.0, 0.0))
    st = status_of(stack, gid, lambda m: m.state == "PLANNING" and m.reason.startswith("no plan: "), 60.0,
                   "the no-plan reason")
    assert "off the costmap" in st.reason, st.reason
    assert "planner_patience" in st.reason, st.reason
    status_of(stack, gid, lambda m: m.state == "CLEARING" and "rotate in place" in m.reason, 120.0,
              "the rotate-in-place recovery")
    assert stack.status.last().reason.startswith("recovery 2/4: rotate in place"), stack.status.last().reason
    t = wait_until(lambda: (c := stack.cmd.since(0)) and abs(c[-1][1].angular.z) > 0 and c[-1][0], 30.0,
                 "the recovery rotation command")
    wait_until(lambda: len(stack.cmd.since(t)) >= 5 and abs(stack.gt.latest().twist.angular.z) > 0.1, 30.0,
             "the robot rotating")
    assert stack.status.last().state == "CLEARING"
    delay = cancel_and_measure(stack)
    RESULTS.append(f"room/dwa cancel while CLEARING (rotate recovery): first zero cmd_vel after "
                   f"{delay * 1000:.0f} ms")
    assert delay <= CANCEL_LATENCY_S, delay


def test_nav_e2e_a_robot_held_in_place_says_no_progress_and_zenav_goal_prints_it(stack):
    """Issue 32: the base does not move (its motors disabled) while move_base keeps CONTROLLING with valid
    commands: the status names it within a few seconds, and `zenav goal` prints it when it gives up."""
    import time

    from common.messages import Empty, Header, MotorState
    from deploy.stack.goals import send_goal
    from testkit.nav_stack import publisher_ready

    motors = stack.node.publisher("cmd_motor_state", reliable=True)  # one-shot commands: never dropped
    state = stack.node.subscribe("motor_state", MotorState)
    publisher_ready(motors)
    motors.publish(MotorState(Header(0.0, "base_link"), False))
    wait_until(lambda: state.latest() is not None and not state.latest().enabled, 30.0, "motors disabled")
    lines: list[str] = []
    t0 = time.monotonic()
    try:
        code, st = send_goal(stack.node, -1.5, 1.2, 0.0, "map", 12.0, echo=lines.append)
        assert code == 2, lines
        assert st is not None and st.state == "CONTROLLING", lines
        assert st.reason.startswith("no progress for "), st.reason
        assert "no result within 12 s: move_base CONTROLLING" in lines[-1] and "no progress for" in lines[-1], lines
        # said within a few seconds of controlling: no_progress_report is 5 s of sim time (2.5 s wall)
        seen = stack.status.since(t0)
        t_ctrl = next(t for t, m in seen if m.state == "CONTROLLING")
        t_said = next(t for t, m in seen if m.reason.startswith("no progress for "))
        assert t_said - t_ctrl < 8.0, (t_ctrl, t_said)
    finally:
        stack.cancel_pub.publish(Empty())
        motors.publish(MotorState(Header(0.0, "base_link"), True))
        wait_until(lambda: state.latest() is not None and state.latest().enabled, 30.0, "motors enabled")
        wait_until(lambda: stack.status.last().state == "IDLE", 30.0, "move_base idle after the cancel")
