"""Goals, cancels and their status against a NavStack, as `zenav goal` sends them (the navigation tests and
bench/cancel.py)."""

from __future__ import annotations

import time
import uuid

from common.delivery import send_goal
from common.geometry import Pose2D
from common.messages import Empty, GoalStatus, Header, MoveBaseGoal, PoseStamped
from testkit.nav_stack import NavStack
from testkit.wait import wait_until


def cancel_and_measure(stack: NavStack) -> float:
    """Publish move_base/cancel; returns the delay (s) to the first zero Twist on cmd_vel, and checks that
    no non-zero command follows it."""
    t_pub = time.monotonic()
    stack.cancel_pub.publish(Empty())
    first = wait_until(lambda: next((t for t, m in stack.cmd.since(t_pub) if m.is_zero()), None), 10.0,
                     "a zero cmd_vel after cancel")
    done = wait_until(lambda: (m := stack.status.last()).status == GoalStatus.PREEMPTED and m.state == "IDLE"
                      and m, 10.0, "status PREEMPTED")
    assert done.reason == f"goal cancelled by {stack.node.name}", done.reason  # says who cancelled
    n = len(stack.status.since(first))  # move_base keeps publishing status every cycle: watch a few more
    wait_until(lambda: len(stack.status.since(first)) >= n + 5, 10.0, "more move_base/status")
    later = [m for t, m in stack.cmd.since(first) if not m.is_zero()]
    assert not later, f"non-zero cmd_vel after the cancel: {later[:3]}"
    return first - t_pub


def send_goal_async(stack: NavStack, goal: tuple[float, float, float], frame: str = "map",
                    gid: str | None = None):
    """Send a goal as `zenav goal` does (acknowledged by move_base) and return its id once move_base has
    taken it in; does not wait for the result. ``gid``: resend a known goal (returns move_base's answer)."""
    new = gid is None
    gid = gid or f"nav-{uuid.uuid4().hex[:8]}"
    answer = send_goal(stack.node, MoveBaseGoal(gid, PoseStamped(Header(0.0, frame), Pose2D(*goal).to_transform())),
                       deadline=60.0)
    assert answer.goal_id == gid, answer
    return gid if new else answer


def status_of(stack: NavStack, gid: str, pred, timeout: float, what: str):
    """Wait for a move_base/status of goal ``gid`` satisfying ``pred``; returns it."""
    def find():
        m = stack.status.last()
        return m if m is not None and m.goal_id == gid and pred(m) else None
    return wait_until(find, timeout, what, alive=stack.dead)
