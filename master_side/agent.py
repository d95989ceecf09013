"""The master agent: ``zenav master --config FILE [--robot NAME]``.

Same mechanism as the robot agent (``common.supervisor`` + ``common.launch``) for the master's nodes
(costmaps, planners, move_base, SLAM, map server). One section, ``nodes:``::

    robot: pioneer1
    use_sim_time: true
    nodes:
      map_server: {module: master_side.mapping.map_server_node, params: {map: maps/room.yaml}}
      move_base:
        module: master_side.planning.move_base_node
        config: move_base.yaml          # or params: {...}
        respawn: true
        wait_for: [map, odom]

``--map FILE`` points the map server at another map (``map_server.map``); ``--set NODE.KEY=VALUE``
changes any node's parameter (repeatable), e.g. ``--set localization.initial_pose_x=1.5`` — so one shipped
file serves every world and start, as roslaunch arguments do.

Before starting anything every node's parameters are checked (a node module's ``check``, see
``common.node_check``): all problems of all nodes in one message and exit status 2; parameters that
ROS knows but that have no effect in zenav are listed once, per node, as a warning.
Exit status: 0 after Ctrl-C / SIGTERM, 1 when a required node ended or failed, 2 for a bad config.
"""

from __future__ import annotations

import argparse
import os
import sys

from common.agent_run import run_agent
from common.config import ConfigError
from common.launch import Launch, Section, load_launch
from common.node_check import format_config_error

SECTIONS = [Section("nodes")]
EXIT_CONFIG = 2


MAP_SERVER_MODULE = "master_side.mapping.map_server_node"


def load(path: str, map_file: str | None = None, sets: list[str] | tuple[str, ...] = ()) -> Launch:
    """The validated launch of a master config, with ``--map`` and ``--set`` applied."""
    launch = load_launch(path, SECTIONS)
    if map_file is not None:
        servers = [e for e in launch.entries if e.opts.module == MAP_SERVER_MODULE]
        if not servers:
            raise ConfigError(path, "nodes", f"--map needs a map server node (module {MAP_SERVER_MODULE})")
        if not os.path.isfile(map_file):
            raise ConfigError("--map", "map", f"file not found: {map_file}")
        for e in servers:
            launch.override(e.name, map=os.path.abspath(map_file))
    for assignment in sets:
        launch.set(assignment)
    return launch


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--config", required=True, metavar="FILE", help="master YAML with a nodes: section")
    p.add_argument("--map", metavar="FILE", help="map YAML for the map server (overrides its map: parameter)")
    p.add_argument("--set", action="append", default=[], metavar="NODE.KEY=VALUE",
                   help="override one node parameter, e.g. --set localization.initial_pose_x=1.5 (repeatable; "
                        "the value is read as YAML)")
    p.add_argument("--robot", metavar="NAME", default=argparse.SUPPRESS,
                   help="robot served (keys zenav/<robot>/...); "
                                                   "default $ZENAV_ROBOT, then the file's robot:")


def run(args: argparse.Namespace) -> int:
    try:
        launch = load(args.config, getattr(args, "map", None), getattr(args, "set", None) or ())
    except ConfigError as e:
        print(format_config_error("master", e), file=sys.stderr)
        return EXIT_CONFIG
    return run_agent("master", launch, robot=getattr(args, "robot", None))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="zenav master", description=__doc__.split("\n\n")[0])
    add_arguments(ap)
    return run(ap.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
