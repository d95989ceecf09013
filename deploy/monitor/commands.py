"""The web page's tools on the bus: goal, cancel and initial pose, each acknowledged by the node that acts
on it."""

from __future__ import annotations


def bus_commands(session, robot: str, deadline: float = 20.0):
    """``send(what, msg)`` for the page's tools: each command acknowledged by the node that acts on it
    (common/delivery.py), so the page says "accepted by move_base" or who did not answer — never a
    silent put into a link that is down."""
    import uuid

    from common.bus import Node, ServiceError
    from common.delivery import DeliveryFailed, cancel_goal, send_acknowledged, send_goal
    from common.messages import GoalStatus, MoveBaseGoal, PoseStamped
    from deploy.monitor.webserver import CommandNotAcknowledged

    node = Node(f"monitor_web_{uuid.uuid4().hex[:6]}", robot=robot, session=session)

    def send(what: str, msg) -> str:
        try:
            if what == "goal":
                gid = f"web-{uuid.uuid4().hex[:8]}"
                st = send_goal(node, MoveBaseGoal(gid, msg), deadline)
                if st.status == GoalStatus.REJECTED:
                    raise ValueError(f"move_base rejected the goal: {st.reason}")
                return f"goal {gid} accepted by move_base"
            if what == "cancel":
                st = cancel_goal(node, "", deadline)
                return f"cancel acknowledged by move_base ({st.goal_id or 'no goal'})"
            pose = send_acknowledged(node, "set_initial_pose", msg, PoseStamped, deadline,
                                     what=f"AMCL of robot '{robot}'").pose.to_pose2d()
            return f"AMCL set its pose to ({pose.x:.2f}, {pose.y:.2f})"
        except DeliveryFailed as e:
            raise CommandNotAcknowledged(str(e)) from None
        except ServiceError as e:  # the node answered: no (e.g. AMCL without a map yet)
            raise ValueError(str(e)) from None

    send.node = node  # closed with the monitor
    return send
