"""Send one navigation goal to move_base and follow it to its result (``zenav goal``, the demo, the test
kit): acknowledged delivery, progress lines through ``echo``, the reason when it ends or gives up."""

from __future__ import annotations

import threading
import time
import uuid


def send_goal(node, x: float, y: float, yaw: float, frame: str, timeout: float, echo=print,
              cancel: threading.Event | None = None, wait: float = 60.0):
    """Send one goal and wait; returns (exit code, final MoveBaseStatus or None).

    The goal goes through move_base's acknowledged service (common/delivery.py): retried until move_base
    answers or ``wait`` s pass — then one line saying so, exit 2. A goal sent while the link is down
    is thus either taken in once the link is back or reported failed, never silently lost."""
    from common.delivery import DeliveryFailed, cancel_goal, last_seen
    from common.delivery import send_goal as send_acknowledged_goal
    from common.geometry import Pose2D
    from common.messages import GoalStatus, Header, MoveBaseGoal, MoveBaseStatus, PoseStamped

    gid = f"goal-{uuid.uuid4().hex[:8]}"
    status = node.subscribe("move_base/status", MoveBaseStatus, mode="latest")
    result = node.subscribe("move_base/result", MoveBaseStatus, mode="queue")
    seen = last_seen(status, "its status")
    goal = MoveBaseGoal(gid, PoseStamped(Header(node.clock.now(), frame), Pose2D(x, y, yaw).to_transform()))
    t0 = time.monotonic()
    echo(f"goal {gid}: ({x:.2f}, {y:.2f}, {yaw:.2f}) in {frame}, to move_base of robot '{node.robot}'")
    try:
        answer = send_acknowledged_goal(node, goal, min(timeout, wait), seen,
                                        cancelled=lambda: cancel is not None and cancel.is_set())
    except DeliveryFailed as e:
        if cancel is not None and cancel.is_set():
            return 1, None
        echo(f"zenav goal: {e} (is `zenav master` running, and is --robot right? `zenav nodes` lists what "
             f"is there)")
        return 2, None
    if answer.status == GoalStatus.REJECTED:
        return _final(answer, gid, echo)
    echo(f"goal {gid}: accepted by move_base after {time.monotonic() - t0:.1f} s")
    last_line, last_print, last_heard = "", 0.0, time.monotonic()
    while time.monotonic() - t0 < timeout:
        if cancel is not None and cancel.is_set():
            cancel = None
            try:
                s = cancel_goal(node, gid, seen=seen)
                echo(f"goal {gid}: cancel acknowledged")
                return _final(s, gid, echo) if s.status != GoalStatus.ACTIVE else (1, s)
            except DeliveryFailed as e:
                echo(f"goal {gid}: cancel not acknowledged: {e}")
                return 2, status.latest()
        try:
            r = result.get(timeout=0.2)
            if r.goal_id == gid:
                return _final(r, gid, echo)
        except TimeoutError:
            pass
        s = status.latest()
        if s is not None and s.goal_id == gid and status.last_receive_time > last_heard:
            last_heard = status.last_receive_time
            line = f"  {s.state:<11} {s.distance_to_goal_m:5.2f} m to go  {s.reason}"
            if line != last_line or time.monotonic() - last_print > 5.0:
                echo(line)
                last_line, last_print = line, time.monotonic()
            if s.status in (GoalStatus.SUCCEEDED, GoalStatus.ABORTED, GoalStatus.PREEMPTED,
                            GoalStatus.REJECTED) and s.state == "IDLE":
                return _final(s, gid, echo)
        elif time.monotonic() - last_heard > 3.0:
            # no word on our goal for 3 s (a cut link, a result lost on the way): ask move_base itself;
            # the same goal id again is answered with its state and never restarts it
            last_heard = time.monotonic()
            try:
                s = send_acknowledged_goal(node, goal, 2.0, seen)
            except DeliveryFailed as e:
                echo(f"  (no answer from move_base: {e})")
                continue
            if s.status in (GoalStatus.SUCCEEDED, GoalStatus.ABORTED, GoalStatus.PREEMPTED, GoalStatus.REJECTED):
                return _final(s, gid, echo)
    s = status.latest()
    why = ""
    if s is not None and s.goal_id == gid:
        why = f": move_base {s.state}, {s.distance_to_goal_m:.2f} m to go, {s.reason or 'no reason given'}"
    echo(f"goal {gid}: no result within {timeout:.0f} s{why}")
    return 2, s


def _final(s, gid: str, echo):
    from common.messages import GoalStatus

    names = {GoalStatus.SUCCEEDED: "SUCCEEDED", GoalStatus.ABORTED: "ABORTED",
             GoalStatus.PREEMPTED: "PREEMPTED (cancelled)", GoalStatus.REJECTED: "REJECTED"}
    used = s.goal_used.pose.to_pose2d()
    echo(f"goal {gid}: {names.get(s.status, s.status)} — {s.reason}")
    echo(f"  goal used ({used.x:.2f}, {used.y:.2f}, {used.theta:.2f}), {s.goal_offset_m:.2f} m from the "
         f"requested one; {s.distance_to_goal_m:.2f} m from the robot at the end")
    return (0 if s.status == GoalStatus.SUCCEEDED else 1), s
