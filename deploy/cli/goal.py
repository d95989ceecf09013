"""``zenav goal X Y YAW [--frame F]``: send a navigation goal to move_base and follow it; ``zenav goal
--waypoints FILE [--loop]``: a mission, one goal after the other (deploy/stack/missions.py)."""

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

A mission: --waypoints FILE drives a list of poses in order, a line per leg; a leg that fails is
reported with move_base's reason and the mission goes on (--stop-on-failure: it stops there);
--loop repeats the list until Ctrl-C (a patrol). The file:

    frame: map                 # of every waypoint that names none (default map)
    waypoints:
      - {x: 2.0, y: 1.4, yaw: 1.57, name: door}
      - {x: -2.2, y: 0.0}      # yaw 0 when left out

exit status: 0 goal (every leg) reached, 1 aborted / rejected / cancelled (a leg failed), 2 no answer
from move_base (within --wait seconds of the start, or no result within --timeout), or a bad file
"""


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser("goal", help="send a navigation goal and wait for the result",
                              description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("x", type=finite, nargs="?", help="m")
    p.add_argument("y", type=finite, nargs="?", help="m")
    p.add_argument("yaw", type=finite, nargs="?", help="rad")
    p.add_argument("--frame", default="map", help="frame of the pose (default map)")
    p.add_argument("--timeout", type=positive, default=300.0, help="give up after this many seconds (per leg)")
    p.add_argument("--waypoints", metavar="FILE", help="a mission: drive the poses of this YAML file in order")
    p.add_argument("--loop", action="store_true", help="with --waypoints: start over after the last, until Ctrl-C")
    p.add_argument("--stop-on-failure", action="store_true",
                   help="with --waypoints: stop at the first leg that fails (default: go on to the next)")
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
    pose = (args.x, args.y, args.yaw)
    if args.waypoints is not None and any(v is not None for v in pose):
        print("zenav goal: give either X Y YAW or --waypoints FILE, not both", file=sys.stderr)
        return 2
    if args.waypoints is None and any(v is None for v in pose):
        print("zenav goal: give X Y YAW (metres, metres, radians) or --waypoints FILE", file=sys.stderr)
        return 2
    if args.waypoints is None and (args.loop or args.stop_on_failure):
        print("zenav goal: --loop and --stop-on-failure go with --waypoints", file=sys.stderr)
        return 2
    waypoints = None
    if args.waypoints is not None:  # a bad file is refused before anything opens on the bus
        from common.config import ConfigError
        from deploy.stack.missions import load_mission

        try:
            waypoints = load_mission(args.waypoints)
        except ConfigError as e:
            print(f"zenav goal: {e}", file=sys.stderr)
            return 2
    stop = threading.Event()
    import signal

    signal.signal(signal.SIGINT, lambda *_: stop.set())
    with Node(f"goal_{uuid.uuid4().hex[:6]}", use_sim_time="auto") as node:  # a simulated robot's stamps
        echo = (lambda *_a, **_k: None) if args.quiet else (lambda s: print(s, flush=True))
        if waypoints is not None:
            return _mission(node, waypoints, args, stop, echo)
        code, s = send_goal(node, args.x, args.y, args.yaw, args.frame, args.timeout, echo, stop, args.wait)
        if args.quiet and s is not None:
            print(f"status={s.status} reason={s.reason!r} distance_m={s.distance_to_goal_m:.3f}")
        elif args.quiet:
            print(f"zenav goal: no answer from move_base of robot '{node.robot}'", file=sys.stderr)
        return code



def _mission(node, waypoints, args, stop: threading.Event, echo) -> int:
    from deploy.stack.missions import run_mission

    echo(f"mission: {len(waypoints)} waypoints from {args.waypoints}{', looping until Ctrl-C' if args.loop else ''}"
         f", to move_base of robot '{node.robot}'")
    report = run_mission(node, waypoints, args.timeout, echo, stop, args.wait, args.loop, args.stop_on_failure)
    print(report.summary(), flush=True)
    return report.code
