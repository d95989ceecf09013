"""Acceptance checks of issue 6 run against a NavStack (robot + master processes on a private bus)."""

from __future__ import annotations

import math
import os
import re
import signal
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from common.geometry import Pose2D
from common.messages import GoalStatus
from testkit.nav_goals import cancel_and_measure, send_goal_async, status_of  # noqa: F401 (the tests' imports)
from testkit.nav_stack import REPO, NavStack, pose_error, world_goals, zenav_command
from tests.support import wait_until

XY_TOL, YAW_TOL = 0.3, 0.1  # the acceptance's bounds, against the simulator's ground truth
# cancel -> the first zero cmd_vel here, in wall time: two bus hops and every scheduling delay of a loaded
# machine between (141 ms once with both workers busy, 15-40 ms otherwise). The 100 ms target is measured
# where load is controlled, `python bench/cancel.py` (README); this bound still fails a stop that waits on
# a service timeout (1 s), the goal's end or a stuck lock, and the check below fails any command after it.
CANCEL_LATENCY_S = 0.5
RESULTS: list[str] = []  # one line per goal, printed at the end of the session (see conftest)


@dataclass
class GoalRun:
    name: str
    goal: tuple[float, float, float]  # requested, in map (for base_link goals: the expected map pose)
    code: int
    status: object  # final MoveBaseStatus
    truth: Pose2D  # ground truth once the robot stood still
    cmds: list  # (wall time, Twist) between sending the goal and the result
    xy_err: float
    yaw_err: float
    statuses: list = field(default_factory=list)  # (wall time, MoveBaseStatus) over the same span
    xy_goal_tolerance: float = 0.0  # the local planner's

    def line(self, stack: NavStack) -> str:
        return (f"{stack.world}/{stack.planner} {self.name}: code {self.code} "
                f"xy {self.xy_err:.3f} m yaw {self.yaw_err:.3f} rad; "
                f"{self.status.reason if self.status else '-'}")


def wait_still(stack: NavStack, timeout: float = 20.0) -> Pose2D:
    """Ground truth once the simulated base has stopped (v = w = 0)."""
    def still():
        m = stack.gt.latest()
        return m is not None and m.twist.linear.x == 0.0 and m.twist.angular.z == 0.0 and m
    return wait_until(still, timeout, "the robot to stand still", alive=stack.dead).pose2d


def run_goal(stack: NavStack, name: str, goal: tuple[float, float, float], frame: str = "map",
             expected: tuple[float, float, float] | None = None, timeout: float = 150.0) -> GoalRun:
    code, st, t0, t1 = stack.goal(*goal, frame=frame, timeout=timeout)
    truth = wait_still(stack)
    target = expected or goal
    xy, yaw = pose_error(truth, target)
    span = lambda tl: [(t, m) for t, m in tl.since(t0) if t <= t1 + 0.05]  # noqa: E731
    run = GoalRun(name, target, code, st, truth, span(stack.cmd), xy, yaw, span(stack.status),
                  stack.local_planner_params().xy_goal_tolerance)
    RESULTS.append(run.line(stack))
    return run


def final_rotation(run: GoalRun) -> list[tuple[float, float]]:
    """(receive time, angular.z) of the final in-place rotation: the commands after the last translating
    one and after the last status that put the robot outside the planner's xy goal tolerance. (An
    in-place turn toward the path just before the robot enters the tolerance is not part of it: the
    rotation to the goal yaw may rightly go the other way. move_base publishes a cycle's status after
    its command, so a command received after that status was computed inside the tolerance.)"""
    outside = [t for t, s in run.statuses if s.distance_to_goal_m > run.xy_goal_tolerance]
    entered = max(outside, default=float("-inf"))
    last_move = max((i for i, (_, m) in enumerate(run.cmds) if abs(m.linear.x) > 1e-9), default=-1)
    return [(t, m.angular.z) for t, m in run.cmds[last_move + 1:] if abs(m.angular.z) > 1e-9 and t > entered]


def final_rotation_signs(run: GoalRun) -> list[float]:
    return [w for _, w in final_rotation(run)]


def check_final_rotation(run: GoalRun) -> None:
    """The final in-place rotation never turns back — unless a control cycle came late before it did
    (a starved process on a loaded machine keeps the last command on the base; turning back is then
    the right recovery, and it is reported). Late: a gap between commands over 1.5 times the run's
    median, i.e. a control cycle missed (seen: 0.156 s at a 0.083 s median, then a 0.023 rad/s turn back)."""
    rot = final_rotation(run)
    flips = [i for i in range(1, len(rot)) if rot[i][1] * rot[i - 1][1] < 0]
    if not flips:
        return
    gaps = np.diff([t for t, _ in run.cmds])
    period = float(np.median(gaps)) if len(gaps) else 0.0
    late = max((b[0] - a[0] for a, b in zip(rot[:flips[0]], rot[1:flips[0] + 1])), default=0.0)
    trace = ", ".join(f"{w:+.3f} rad/s at +{t - rot[0][0]:.3f} s" for t, w in rot)
    assert late > 1.5 * period, f"{run.name}: the final rotation reversed with regular cycles " \
                                f"(period {period:.3f} s): {trace}"
    RESULTS.append(f"{run.name}: final rotation turned back after a late control cycle ({late:.3f} s, "
                   f"period {period:.3f} s)")


def check_world_goals(stack: NavStack) -> list[GoalRun]:
    """Every goal of the world's ``goals:``, in order: reached within 0.3 m / 0.1 rad of ground truth,
    no collision, and the final in-place rotation never reverses."""
    before = stack.collision_count()
    runs = []
    for name, goal in world_goals(stack.world).items():
        run = run_goal(stack, name, goal)
        runs.append(run)
        assert run.code == 0, f"{name}: {run.line(stack)}\n{stack.logs()}"
        assert run.status.status == GoalStatus.SUCCEEDED, run.line(stack)
        assert run.xy_err <= XY_TOL, run.line(stack)
        assert run.yaw_err <= YAW_TOL, run.line(stack)
        assert stack.collision_count() == before, f"{name}: collision {stack.collisions.last()}"
        assert run.status.goal_offset_m == 0.0, f"{name}: a free goal was moved: {run.status}"
        check_final_rotation(run)
    # the final-rotation check must have had something to look at
    assert any(len(final_rotation_signs(r)) >= 3 for r in runs), [final_rotation_signs(r) for r in runs]
    return runs


def check_base_link_goal(stack: NavStack, offset: tuple[float, float, float]) -> GoalRun:
    """A goal relative to base_link lands at (ground truth at send time) ∘ offset. The offset is chosen
    for the world's start pose: a robot left elsewhere (an earlier test failed) is driven there first."""
    start = world_goals(stack.world).get("back_to_start")
    if start is not None and pose_error(wait_still(stack), start)[0] > XY_TOL:
        assert run_goal(stack, "back to the start first", start).code == 0, stack.logs()
    at_send = wait_still(stack)
    exp = at_send.compose(Pose2D(*offset))
    run = run_goal(stack, "base_link goal", offset, frame="base_link", expected=(exp.x, exp.y, exp.theta))
    assert run.code == 0, run.line(stack)
    assert run.xy_err <= XY_TOL, run.line(stack)
    assert run.yaw_err <= YAW_TOL, run.line(stack)
    used = run.status.goal.pose.to_pose2d()  # move_base's goal in map: the same pose
    assert math.hypot(used.x - exp.x, used.y - exp.y) < 0.05, (used, exp)
    check_final_rotation(run)
    return run


def check_stale_tf_reason(stack: NavStack, goal: tuple[float, float, float]) -> GoalRun:
    """Pause fake_localization (map -> odom goes stale) while the robot drives: move_base stops and says
    'stale TF: ...' with the edge and its age; resumed, it reaches the goal."""
    pid = stack.master_proc.child_running("robot_side.sim.fake_localization")
    assert pid, "fake_localization process not found"
    start = wait_still(stack)
    gid = send_goal_async(stack, goal)
    t0 = time.monotonic()
    status_of(stack, gid, lambda m: m.state == "CONTROLLING", 60.0, "CONTROLLING")
    wait_until(lambda: math.hypot(stack.truth().x - start.x, stack.truth().y - start.y) > 0.3, 60.0,
             "the robot to move", alive=stack.dead)
    os.kill(pid, signal.SIGSTOP)
    try:
        st = status_of(stack, gid, lambda m: m.reason.startswith("stale TF"), 30.0, "a stale-TF reason")
        t_stale = time.monotonic()
        assert re.search(r"stale TF: map <- base_link is \d+\.\d+ s old", st.reason), st.reason
        assert "map -> odom" in st.reason, st.reason  # the edge that stopped
        assert st.status == GoalStatus.ACTIVE, st
        wait_until(lambda: (c := stack.cmd.since(t_stale)) and c[-1][1].is_zero(), 5.0, "zero cmd_vel")
        stopped = wait_still(stack)
        t_check = time.monotonic()
        wait_until(lambda: len(stack.cmd.since(t_check)) >= 5, 10.0, "more cmd_vel")
        assert all(m.is_zero() for _, m in stack.cmd.since(t_check)), "moving on a stale pose"
        assert stack.status.last().reason.startswith("stale TF"), stack.status.last().reason
    finally:
        os.kill(pid, signal.SIGCONT)
    try:
        res = status_of(stack, gid, lambda m: m.state == "IDLE", 120.0, "the goal to end")
    except AssertionError as e:  # which stream stopped after the pause (fake_localization's inputs, or tf)
        raise AssertionError(f"{e}; last status: {stack.status.last()}\n--- links\n{stack.links()}\n"
                             f"{stack.node_stats()}\n{stack.logs()}") from None
    truth = wait_still(stack)
    xy, yaw = pose_error(truth, goal)
    code = 0 if res.status == GoalStatus.SUCCEEDED else 1
    run = GoalRun("goal with a stale-TF pause", goal, code, res, truth, stack.cmd.since(t0), xy, yaw)
    RESULTS.append(run.line(stack) + f" (stopped at {stopped.x:.2f}, {stopped.y:.2f} during the pause)")
    assert res.status == GoalStatus.SUCCEEDED, res
    assert xy <= XY_TOL, run.line(stack)
    assert yaw <= YAW_TOL, run.line(stack)
    return run


def check_mission_with_an_unreachable_leg(stack: NavStack, tmp: Path, near=(-1.2, 0.0, 0.0)) -> str:
    """`zenav goal --waypoints` (a user's command, as a process) with an unreachable leg first: that leg fails
    with move_base's reason (status says 'no plan: <planner error>' while it tries, then ABORTED naming
    it), the mission goes on and reaches the next waypoint, and exits 1 with a summary naming the failed
    leg. Returns the command's output."""
    mission = tmp / "mission.yaml"
    mission.write_text("waypoints:\n  - {x: 10.0, y: 10.0, name: off the map}\n"
                       f"  - {{x: {near[0]}, y: {near[1]}, yaw: {near[2]}, name: near}}\n")
    env = {**stack.bus_env, "ZENAV_CONNECT": stack.test_endpoint}
    t0, before = time.monotonic(), stack.collision_count()
    r = subprocess.run([*zenav_command(), "goal", "--waypoints", str(mission), "--timeout", "150"], env=env,
                       capture_output=True, text=True, timeout=400, cwd=REPO)
    out = r.stdout + r.stderr
    assert r.returncode == 1, out
    failed = [ln for ln in out.splitlines() if ln.startswith("leg 1/2: FAILED")]
    assert failed and "aborted: no plan" in failed[0], out
    assert any(ln.startswith("leg 2/2: reached") for ln in out.splitlines()), out
    assert "mission: 1 of 2 legs reached; failed: leg 1 'off the map'" in out, out
    reasons = [m.reason for _, m in stack.status.since(t0)]
    no_plan = [x for x in reasons if x.startswith("no plan: ")]
    assert no_plan, sorted(set(reasons))
    planner_error = no_plan[0][len("no plan: "):].split(" (for ")[0]
    assert planner_error and planner_error in failed[0], (planner_error, failed[0])
    assert stack.collision_count() == before
    xy, _ = pose_error(wait_still(stack), near)
    assert xy <= stack.local_planner_params().xy_goal_tolerance + 0.05, out
    RESULTS.append(f"{stack.world}/{stack.planner} mission: {failed[0]}; leg 2 reached, {xy:.3f} m off")
    return out
