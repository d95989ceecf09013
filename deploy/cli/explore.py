"""``zenav explore``: map a building by itself (explore_lite's role) while SLAM runs."""

from __future__ import annotations

import argparse
import sys
import threading
import uuid

from common.argtypes import positive

DESCRIPTION = """\
Drive the robot to the frontiers between known free space and unknown space on SLAM's map, one after
the other, while SLAM builds it (zenav master --config master_side/config/p3at_slam_zenav.yaml), until no
frontier is left; then save the map (--save NAME, default 'explored'). Ctrl-C stops, cancels the goal
and saves the map too. Frontiers, their cost and the choice are explore_lite's: the cheapest of
(potential_scale x distance - gain_scale x size) x the map's resolution, frontiers under min_frontier_size ignored, a
target blacklisted when move_base gives up on it or after progress_timeout without getting nearer (zenav:
nor driving progress_travel on its way, for up to 4 progress_timeouts); free
space nearer a wall than inscribed_radius does not count as reachable; goals avoid what move_base's global
costmap forbids. Nothing left to go to must last done_timeout (15 s, the robot looking around meanwhile)
before exploration ends.

Goals failing one after another (stuck_failures, 3) with the robot where it stood at the first end the run
as stuck, saying where and move_base's last reason; the map is saved.

exit status: 0 nothing left to explore, 1 stopped, 2 no map or no move_base (SLAM not running), bad --params,
3 stuck: the robot could not move on
"""


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser("explore", help="explore: drive to frontiers until the map is complete",
                              description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--params", metavar="FILE", help="explore_lite parameters (YAML: planner_frequency, "
                                                    "progress_timeout, potential_scale, gain_scale, min_frontier_size; "
                                                    "zenav's: done_timeout, look_around, ...)")
    p.add_argument("--save", default="explored", metavar="NAME", help="map files written at the end (NAME.pgm/.yaml)")
    p.add_argument("--no-save", action="store_true", help="do not save the map at the end")
    p.add_argument("--wait", type=positive, default=30.0, metavar="S",
                   help="exit 2 when no map or no move_base came within S seconds")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    import signal

    from common.bus import Node
    from common.config import ConfigError, load_params, read_yaml
    from deploy.cli.session import one_robot
    from deploy.stack.explore import explore
    from master_side.exploration.explorer import ExploreParams

    try:
        params = load_params(ExploreParams, read_yaml(args.params) if args.params else {}, args.params or "<defaults>")
    except ConfigError as e:
        print(f"zenav explore: {e}", file=sys.stderr)
        return 2
    one_robot(args)
    stop = threading.Event()
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    # the robot's time when it is simulated (TF is stamped with it): explore_lite follows /clock with use_sim_time
    with Node(f"explore_{uuid.uuid4().hex[:6]}", use_sim_time="auto") as node:
        report = explore(node, params, lambda s: print(s, flush=True), stop, args.wait)
        if report.code == 2:  # nothing explored: one line saying why
            print(f"zenav explore: {report.why}", file=sys.stderr)
            return 2
        print(report.summary(), flush=True)
        if not args.no_save:
            _save(report.map, args.save)
    return report.code


def _save(grid, name: str) -> None:
    """The last map the run saw, as map_server files."""
    from master_side.mapping.map_io import save_map

    if grid is None:
        print("zenav explore: no map to save", file=sys.stderr)
        return
    print(f"map saved: {save_map(grid, name)}", flush=True)
