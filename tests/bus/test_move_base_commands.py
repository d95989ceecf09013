"""move_base's acknowledged commands and its watched cmd_vel route, in process on a loopback bus: a goal
sent through ``move_base/send_goal`` is answered ACTIVE, the same id again is answered and not restarted,
``move_base/cancel_goal`` answers PREEMPTED; while no subscriber of cmd_vel is reachable the status says so,
and stops saying it once one is."""

from __future__ import annotations

from pathlib import Path

import yaml
from bushelp import wait_for

from common.delivery import cancel_goal, send_goal
from common.geometry import Pose2D, Transform
from common.messages import GoalStatus, Header, MoveBaseGoal, MoveBaseStatus, PoseStamped, TransformStamped, Twist
from common.tf import TFBroadcaster
from master_side.move_base.node import NO_CMD_ROUTE

CONFIG = Path(__file__).resolve().parents[2] / "master_side" / "config"


def test_goals_are_acknowledged_once_and_a_missing_cmd_vel_route_is_named(node_pair):
    from master_side.move_base.node import start

    source = CONFIG / "p3at_known_map.yaml"
    params = yaml.safe_load(source.read_text())["nodes"]["move_base"]["params"]
    tester, mb_node = node_pair("tester"), node_pair("move_base")
    tf = TFBroadcaster(tester)
    tester.timer(0.05, lambda: tf.send([TransformStamped(Header(tester.clock.now(), p), c, Transform())
                                        for p, c in (("map", "odom"), ("odom", "base_link"))]))
    status = tester.subscribe("move_base/status", MoveBaseStatus)
    mb = start(mb_node, params, str(source))
    try:
        wait_for(lambda: mb_node.clock.now() and status.latest() is not None, 30, "move_base's status")
        goal = MoveBaseGoal("g1", PoseStamped(Header(0.0, "map"), Pose2D(1.0, 0.0, 0.0).to_transform()))
        first = send_goal(tester, goal, deadline=30.0)
        assert (first.goal_id, first.status) == ("g1", GoalStatus.ACTIVE), first
        started = mb.machine.goal
        again = send_goal(tester, goal, deadline=30.0)  # a sender's retry
        assert (again.goal_id, again.status) == ("g1", GoalStatus.ACTIVE), again
        assert mb.machine.goal is started, "the resent goal was started again"

        # nothing subscribes to cmd_vel here: the status names the missing route
        st = wait_for(lambda: (s := status.latest()) and s.goal_id == "g1" and NO_CMD_ROUTE in s.reason and s,
                      30, "the missing cmd_vel route in the status")
        assert st.status == GoalStatus.ACTIVE
        base = node_pair("base")
        base.subscribe("cmd_vel", Twist)
        wait_for(lambda: mb.cmd.matching, 30, "move_base's cmd_vel matched")
        wait_for(lambda: (s := status.latest()) and s.goal_id == "g1" and NO_CMD_ROUTE not in s.reason, 30,
                 "the route no longer named")

        done = cancel_goal(tester, "g1", deadline=30.0)
        assert (done.goal_id, done.status) == ("g1", GoalStatus.PREEMPTED), done
        late = send_goal(tester, goal, deadline=30.0)  # an old retry arriving after the cancel
        assert (late.goal_id, late.status) == ("g1", GoalStatus.PREEMPTED), late
        assert mb.machine.goal is started and mb.machine.status == GoalStatus.PREEMPTED
        unknown = cancel_goal(tester, "nope", deadline=30.0)
        assert unknown.status == GoalStatus.LOST, unknown
    finally:
        mb.close()
