"""cmd_vel from one fleet host's identity, and a counter of what reaches a robot (netns test helper).

    python cmd_vel_proc.py pub VX WZ SECONDS   publish Twist(VX, WZ) on cmd_vel at 20 Hz for SECONDS;
                                               exit 3 ("REFUSED ...") when the Zenoh session cannot open
    python cmd_vel_proc.py count SECONDS       count the cmd_vel messages that arrive, by (vx, wz), and how
                                               far the simulator's ground_truth gets from where it was at
                                               READY (printed once the first ground_truth arrived); one
                                               JSON line at the end: after SECONDS or once $COUNT_UNTIL
                                               ("vx,wz") was seen 10 times

The bus settings and identity are the environment's (a host's zenav.env: ZENAV_*); ZENAV_ROBOT names the
robot whose cmd_vel it is.
"""

from __future__ import annotations

import json
import math
import os
import sys
import threading
import time
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from common.bus import Node  # noqa: E402
from common.messages import Odometry, Twist  # noqa: E402


def _node() -> Node:
    try:
        return Node("fleet_test_cmd_vel")
    except Exception as e:  # noqa: BLE001 - zenoh.ZError: refused credentials, no router
        print(f"REFUSED {e}", flush=True)
        sys.exit(3)


def pub(vx: float, wz: float, seconds: float) -> int:
    node = _node()
    print("OPEN", flush=True)
    p = node.publisher("cmd_vel")
    n, end = 0, time.monotonic() + seconds
    while time.monotonic() < end:
        p.publish(Twist.planar(vx, wz))
        n += 1
        time.sleep(0.05)
    print(f"SENT {n}", flush=True)
    node.close()
    return 0


def count(seconds: float) -> int:
    node = _node()
    seen: Counter = Counter()
    until = tuple(float(x) for x in os.environ["COUNT_UNTIL"].split(",")) if os.environ.get("COUNT_UNTIL") else None
    done, first, moved = threading.Event(), [], [0.0]

    def on_msg(m: Twist) -> None:
        k = (round(m.linear.x, 3), round(m.angular.z, 3))
        seen[k] += 1
        if until and seen[until] >= 10:
            done.set()

    def on_truth(m: Odometry) -> None:
        t = m.pose.translation
        if not first:
            first.append((t.x, t.y))
        moved[0] = max(moved[0], math.hypot(t.x - first[0][0], t.y - first[0][1]))

    node.subscribe("ground_truth", Odometry, callback=on_truth, mode="queue")
    deadline = time.monotonic() + seconds
    while not first and time.monotonic() < deadline:
        time.sleep(0.05)
    node.subscribe("cmd_vel", Twist, callback=on_msg, mode="queue")
    print("READY" if first else "NO ground_truth", flush=True)
    done.wait(max(0.0, deadline - time.monotonic()))
    out = {f"{vx},{wz}": n for (vx, wz), n in seen.items()}
    print(json.dumps({"cmd_vel": out, "start": first[0] if first else None, "moved": round(moved[0], 4)}), flush=True)
    node.close()
    return 0


if __name__ == "__main__":
    if sys.argv[1] == "pub":
        sys.exit(pub(float(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4])))
    sys.exit(count(float(sys.argv[2])))
