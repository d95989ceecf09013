"""A bus peer for the network-fault tests, run on the robot's side of the link (its namespace).

Prints one line per event, wall time first (the robot PC's clock)::

    GT t x y yaw v stamp w  ground truth, 50 Hz        SAFE t v w     what the base is told
    CMD t v w sim           cmd_vel from the master    COLL t count stamp x y   a collision (sim time, where)
    MON t action            collision monitor state    ST t status goal_id state reason   move_base/status

``stamp`` is ground truth's header stamp and ``sim`` the last simulated clock seen when the command came:
the robot's own time, which runs slower than the wall clock when the simulator falls behind on a busy machine.

``probe.py teleop`` runs on the master's side instead: stdin ``drive V W`` streams cmd_vel (V m/s, W rad/s)
at 20 Hz, as a teleop node on the master PC would, until ``stop`` (answers ``DRIVING`` / ``STOPPED``).

stdin: ``goal X Y YAW`` (map frame): sent as `zenav goal` sends it (acknowledged by move_base, retried
inside up to 90 s), then ``ACK goal_id status`` or ``NOACK goal_id why``; ``box DX DY SX SY`` (a box
appears relative to the robot): ``SENDING box`` before its put and ``SENT box`` after it.
"""

from __future__ import annotations

import sys
import threading
import time
import uuid

from common.bus import Node
from common.delivery import DeliveryFailed, send_goal
from common.geometry import Pose2D
from common.messages import (
    Clock,
    Collision,
    CollisionMonitorState,
    Header,
    MoveBaseGoal,
    MoveBaseStatus,
    Odometry,
    PoseStamped,
    SpawnBox,
    Twist,
)

_lock = threading.Lock()


def say(*words) -> None:
    with _lock:
        print(f"{time.time():.3f}", *words, flush=True)


def main() -> None:
    node = Node("netem_probe", use_sim_time=False)
    clock = node.subscribe("clock", Clock)  # latest only, read on the network thread's delivery

    def sim_now() -> float:
        c = clock.latest()
        return c.clock if c is not None else float("nan")
    node.subscribe("ground_truth", Odometry, mode="queue", callback=lambda m: say(
        "GT", f"{m.pose2d.x:.4f}", f"{m.pose2d.y:.4f}", f"{m.pose2d.theta:.4f}", f"{m.twist.linear.x:.4f}",
        f"{m.header.stamp:.4f}", f"{m.twist.angular.z:.4f}"))
    node.subscribe("cmd_vel", Twist, mode="queue",
                   callback=lambda m: say("CMD", f"{m.linear.x:.4f}", f"{m.angular.z:.4f}", f"{sim_now():.4f}"))
    node.subscribe("safety/cmd_vel", Twist, mode="queue",
                   callback=lambda m: say("SAFE", f"{m.linear.x:.4f}", f"{m.angular.z:.4f}"))
    node.subscribe("collision", Collision, mode="queue", callback=lambda m: say(
        "COLL", m.count, f"{m.header.stamp:.4f}", f"{m.x:.4f}", f"{m.y:.4f}"))
    node.subscribe("collision_monitor/state", CollisionMonitorState, mode="queue",
                   callback=lambda m: say("MON", m.action))
    node.subscribe("move_base/status", MoveBaseStatus, mode="queue",
                   callback=lambda m: say("ST", m.status, m.goal_id or "-", m.state or "-",
                                          (m.reason or "-").replace("\n", " ")))

    def goal(x: float, y: float, yaw: float) -> None:
        gid = f"probe-{uuid.uuid4().hex[:8]}"
        say("SENDING", "goal", gid)
        try:
            st = send_goal(node, MoveBaseGoal(gid, PoseStamped(Header(time.time(), "map"),
                                                               Pose2D(x, y, yaw).to_transform())), deadline=90.0)
            say("ACK", gid, st.status)
        except DeliveryFailed as e:
            say("NOACK", gid, str(e).replace("\n", " "))
    box = node.publisher("sim/spawn_box", reliable=True)  # a one-shot command: never dropped
    say("READY")
    for line in sys.stdin:
        w = line.split()
        if w[:1] == ["goal"]:
            threading.Thread(target=goal, args=tuple(map(float, w[1:4])), daemon=True).start()
        elif w[:1] == ["box"]:
            dx, dy, sx, sy = map(float, w[1:5])
            say("SENDING", "box")
            box.publish(SpawnBox(Header(time.time(), "base_link"), dx, dy, 0.0, sx, sy, 1.0))
            say("SENT", "box")
    node.close()


def teleop() -> None:
    node = Node("netem_teleop", use_sim_time=False)
    pub = node.publisher("cmd_vel")
    stop = threading.Event()

    def stream(v: float, w: float, until: threading.Event) -> None:
        while not until.wait(0.05):
            pub.publish(Twist.planar(v, w))
    say("READY")
    for line in sys.stdin:
        w = line.split()
        if w[:1] == ["drive"]:
            stop.set()
            stop = threading.Event()
            threading.Thread(target=stream, args=(float(w[1]), float(w[2]), stop), daemon=True).start()
            say("DRIVING")
        elif w[:1] == ["stop"]:
            stop.set()
            say("STOPPED")
    stop.set()
    node.close()


if __name__ == "__main__":
    teleop() if sys.argv[1:] == ["teleop"] else main()
