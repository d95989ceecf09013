"""Processes of tests/reliability/test_cut_link_routes.py.

``cut_peer.py robot_node``: run by a robot agent (its child: a client of the agent). Publishes what a
robot-side node does: a 50 Hz stream (``ground_truth``, drop congestion control) and a latched state at
10 Hz from its loop (``state``, as the collision monitor's), both subscribed on the master's side.

``cut_peer.py [master]``: a peer that subscribes to the stream and the state (and the scan, ``master``)
and prints ``t GT`` and ``t STATE`` (wall time) for every message of those two; ``t READY`` once it is
up. Runs until stdin closes.
"""

from __future__ import annotations

import sys
import threading
import time

import numpy as np

from common.bus import Node
from common.messages import Clock, Header, LaserScan, Twist

_lock = threading.Lock()


def say(*words) -> None:
    with _lock:  # one line at a time from the subscriptions' threads
        print(f"{time.time():.3f}", *words, flush=True)


def robot_node() -> None:
    node = Node("cut_robot_node", use_sim_time=False)
    stream = node.publisher("ground_truth")
    scan_pub = node.publisher("scan")
    state = node.publisher("state", latched=True, background=True)
    n = 1081  # a Hokuyo UTM-30LX's beams (270 deg at 0.25 deg), with intensities, at its 40 Hz
    scan = LaserScan(Header(0.0, "laser"), -2.356, 2.356, 4.712 / (n - 1), 0.0, 0.025, 0.1, 30.0,
                     np.full(n, 3.0, np.float32), np.full(n, 100.0, np.float32))
    k = 0
    while True:  # a 200 Hz tick: the stream at 50 Hz, the laser at its 40 Hz, the state at 10 Hz
        k += 1
        if k % 4 == 0:
            stream.publish(Twist.planar(0.1, 0.0))
        if k % 5 == 0:
            scan_pub.publish(scan)
        if k % 20 == 0:
            state.publish(Clock(float(k)))
        time.sleep(0.005)


def listener(master_side: bool) -> None:
    node = Node("cut_listener", use_sim_time=False)
    node.subscribe("ground_truth", Twist, mode="queue", callback=lambda _m: say("GT"))
    node.subscribe("state", Clock, mode="queue", callback=lambda _m: say("STATE"))
    if master_side:
        node.subscribe("scan", LaserScan)
    say("READY")
    done = threading.Event()
    threading.Thread(target=lambda: (sys.stdin.read(), done.set()), daemon=True).start()
    done.wait()
    node.close()


if __name__ == "__main__":
    robot_node() if sys.argv[1:] == ["robot_node"] else listener(sys.argv[1:] == ["master"])
