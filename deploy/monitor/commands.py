"""The web page's tools on the bus: goal, cancel and initial pose, each acknowledged by the node that acts
on it."""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol, cast

if TYPE_CHECKING:
    from common.bus import Node


class BusCommands(Protocol):
    """``send(what, msg)`` and the node it sends from (closed with the monitor)."""

    node: Node

    def __call__(self, what: str, msg: object) -> str: ...


def bus_commands(session, robot: str, deadline: float = 20.0, on_mission=None,
                 leg_timeout: float = 600.0) -> BusCommands:
    """``send(what, msg)`` for the page's tools: each command acknowledged by the node that acts on it
    (common/delivery.py), so the page says "accepted by move_base" or who did not answer — never a
    silent put into a link that is down. "mission" ((poses, loop)) drives the page's waypoint queue in a
    thread (deploy/stack/missions.py, ``leg_timeout`` s a leg), its lines to ``on_mission(line, active)``;
    a new mission or "cancel" stops the running one."""
    import threading
    import uuid

    from common.bus import Node, ServiceError
    from common.delivery import DeliveryFailed, cancel_goal, send_acknowledged, send_goal
    from common.messages import GoalStatus, MoveBaseGoal, PoseStamped
    from deploy.monitor.webserver import CommandNotAcknowledged
    from deploy.stack.missions import Waypoint, run_mission

    node = Node(f"monitor_web_{uuid.uuid4().hex[:6]}", robot=robot, session=session)
    say = on_mission or (lambda _line, _active=True: None)
    running: dict = {"cancel": threading.Event(), "thread": None}

    def stop_mission() -> None:
        running["cancel"].set()
        t = running["thread"]
        if t is not None:
            t.join(timeout=deadline)

    def mission(poses, loop: bool) -> str:
        stop_mission()
        wps = [Waypoint(p.x, p.y, p.theta, frame) for p, frame in
               ((m.pose.to_pose2d(), m.header.frame_id or "map") for m in poses)]
        cancel = threading.Event()

        def drive() -> None:
            report = run_mission(node, wps, leg_timeout, echo=say, cancel=cancel, wait=deadline, loop=loop)
            say(report.summary(), False)

        running["cancel"], running["thread"] = cancel, threading.Thread(target=drive, daemon=True,
                                                                       name="web-mission")
        running["thread"].start()
        return f"mission of {len(wps)} waypoints started" + (" (loop)" if loop else "")

    def send(what: str, msg) -> str:
        try:
            if what == "mission":
                return mission(*msg)
            if what == "goal":
                gid = f"web-{uuid.uuid4().hex[:8]}"
                st = send_goal(node, MoveBaseGoal(gid, msg), deadline)
                if st.status == GoalStatus.REJECTED:
                    raise ValueError(f"move_base rejected the goal: {st.reason}")
                return f"goal {gid} accepted by move_base"
            if what == "cancel":
                if running["thread"] is not None and running["thread"].is_alive():
                    running["cancel"].set()  # the mission's send_goal cancels its goal as it ends
                st = cancel_goal(node, "", deadline)
                return f"cancel acknowledged by move_base ({st.goal_id or 'no goal'})"
            pose = send_acknowledged(node, "set_initial_pose", msg, PoseStamped, deadline,
                                     what=f"AMCL of robot '{robot}'").pose.to_pose2d()
            return f"AMCL set its pose to ({pose.x:.2f}, {pose.y:.2f})"
        except DeliveryFailed as e:
            raise CommandNotAcknowledged(str(e)) from None
        except ServiceError as e:  # the node answered: no (e.g. AMCL without a map yet)
            raise ValueError(str(e)) from None

    commands = cast(BusCommands, send)
    commands.node = node  # closed with the monitor
    return commands
