"""The robot agent: ``zenav robot --config FILE [--world W] [--start X Y YAW] [--speed N] [--engine E]``
``[--set NODE.KEY=VALUE] [--robot NAME]``.

Reads one YAML laid out like the tutorial's launch file (section 3.6) and runs every node as its own
process under ``common.supervisor.Supervisor``:

    platform:     PLATFORM SPECIFIC - the base driver (real p2os driver or robot_side.sim.node);
                  entries here default to stop_first: true, so the base stops before anything else
    transforms:   TRANSFORMS - name: {args: "x y z yaw pitch roll parent child [period_ms]"}
                  (or just the string), one common.static_tf_node each
    sensors:      SENSORS CONFIGURATION - laser / depth camera / depth conversion nodes
    safety:       the collision monitor (robot_side.safety.node) between the master's cmd_vel and
                  the base, which then listens on safety/cmd_vel (its cmd_vel_topic)

``--world``, ``--start``, ``--speed`` and ``--engine`` override the ``world``, ``start``, ``speed`` and
``engine`` parameters of the simulator node(s) (module ``robot_side.sim.node``); ``--set`` changes any node's
parameter, a nested one by its path (``--set sim.base.odom_rotation_center_x=-0.12``). Every node's parameters
are checked before anything starts (``common.node_check``). Exit status: 0 after Ctrl-C / SIGTERM, 1 when
a required node ended or failed, 2 for a bad config file.
"""

from __future__ import annotations

import argparse
import os
import sys

from common.agent_run import run_agent
from common.argtypes import finite, positive
from common.config import ConfigError
from common.launch import Launch, Section, load_launch
from common.node_check import format_config_error
from robot_side.sim.physics_params import ENGINES

SIM_MODULE = "robot_side.sim.node"
SECTIONS = [
    Section("platform", stop_first=True),
    Section("transforms", default_module="common.static_tf_node", tf_args=True),
    Section("sensors"),
    Section("safety"),
]
EXIT_CONFIG = 2


def load(path: str, world: str | None = None, start: list[float] | None = None,
         speed: float | None = None, engine: str | None = None, sets: list[str] | tuple[str, ...] = ()) -> Launch:
    """The validated launch of a robot config, with the simulator overrides and ``--set`` applied."""
    launch = load_launch(path, SECTIONS)
    overrides: dict = {}
    if world is not None:
        overrides["world"] = os.path.abspath(world) if os.path.isfile(world) else world
    if start is not None:
        overrides["start"] = [float(v) for v in start]
    if speed is not None:
        if not speed > 0:
            raise ConfigError("--speed", "speed", f"must be > 0, got {speed}")
        overrides["speed"] = float(speed)
    if engine is not None:
        overrides["engine"] = engine
    if overrides:
        sims = [e for e in launch.entries if e.opts.module == SIM_MODULE]
        if not sims:
            opts = "/".join(f"--{k}" for k in overrides)
            raise ConfigError(path, "platform", f"{opts} need a simulator node (module {SIM_MODULE})")
        for e in sims:
            launch.override(e.name, **overrides)
    for assignment in sets:
        launch.set(assignment)
    return launch


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--config", required=True, metavar="FILE",
                   help="robot YAML (platform / transforms / sensors), e.g. robot_side/config/p3at_sim.yaml")
    p.add_argument("--world", metavar="W", help="simulator world file (overrides the config)")
    p.add_argument("--start", nargs=3, type=finite, metavar=("X", "Y", "YAW"),
                   help="simulator start pose in m, m, rad")
    p.add_argument("--speed", type=positive, metavar="N", help="simulated time N x real time")
    p.add_argument("--engine", choices=ENGINES,
                   help="simulator engine: kinematic (exact arcs on a grid) or mujoco (rigid-body physics)")
    p.add_argument("--set", action="append", default=[], metavar="NODE.KEY=VALUE",
                   help="override one node parameter, a nested one by its path, e.g. --set "
                        "sim.base.odom_rotation_center_x=-0.12 (repeatable; the value is read as YAML)")
    p.add_argument("--robot", metavar="NAME", default=argparse.SUPPRESS,
                   help="robot name (keys zenav/<robot>/...); "
                                                   "default $ZENAV_ROBOT, then the file's robot:")


def run(args: argparse.Namespace) -> int:
    try:
        launch = load(args.config, args.world, args.start, args.speed, getattr(args, "engine", None),
                      getattr(args, "set", None) or ())
    except ConfigError as e:
        print(format_config_error("robot", e), file=sys.stderr)
        return EXIT_CONFIG
    return run_agent("robot", launch, robot=getattr(args, "robot", None))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="zenav robot", description=__doc__.split("\n\n")[0])
    add_arguments(ap)
    return run(ap.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
