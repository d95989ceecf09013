"""``zenav goal X Y YAW [--frame F]``: send a navigation goal to move_base and follow it."""

from __future__ import annotations

import argparse
import sys
import threading
import uuid

from common.argtypes import finite, positive

DESCRIPTION = """\
Send a goal to move_base (like publishing on move_base_simple/goal in ROS), print its progress and
wait for the result. The pose may be given in any TF frame: `--frame base_link` means relative to
where the robot is now. Ctrl-C cancels the goal.

The goal is acknowledged by move_base itself (retried until it answers), so a goal sent while the
network is down is taken in once it is back, or reported failed after --wait seconds; never lost.

exit status: 0 goal reached, 1 aborted / rejected / cancelled, 2 no answer from move_base (within
--wait seconds of the start, or no result within --timeout)
"""


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser("goal", help="send a navigation goal and wait for the result",
                              description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("x", type=finite, help="m")
    p.add_argument("y", type=finite, help="m")
    p.add_argument("yaw", type=finite, help="rad")
    p.add_argument("--frame", default="map", help="frame of the pose (default map)")
    p.add_argument("--timeout", type=positive, default=300.0, help="give up after this many seconds")
    p.add_argument("--wait", type=positive, default=20.0, metavar="S",
                   help="exit 2 when move_base has not answered within S seconds (default 20: a link that "
                        "just came back takes up to ~11 s to carry data again, bench/reconnect.py)")
    p.add_argument("--quiet", action="store_true", help="print only the result")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    from common.bus import Node
    from deploy.cli.session import one_robot
    from deploy.stack.goals import send_goal

    one_robot(args)
    stop = threading.Event()
    import signal

    signal.signal(signal.SIGINT, lambda *_: stop.set())
    with Node(f"goal_{uuid.uuid4().hex[:6]}") as node:
        echo = (lambda *_a, **_k: None) if args.quiet else (lambda s: print(s, flush=True))
        code, s = send_goal(node, args.x, args.y, args.yaw, args.frame, args.timeout, echo, stop, args.wait)
        if args.quiet and s is not None:
            print(f"status={s.status} reason={s.reason!r} distance_m={s.distance_to_goal_m:.3f}")
        elif args.quiet:
            print(f"zenav goal: no answer from move_base of robot '{node.robot}'", file=sys.stderr)
        return code

