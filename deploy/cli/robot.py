"""``zenav robot --config FILE [--world W] [--start X Y YAW] [--speed N]`` — the robot agent."""

from __future__ import annotations

import sys


def add_parser(subparsers):
    from robot_side import agent

    p = subparsers.add_parser(
        "robot", help="run the robot's nodes (base, transforms, sensors) from one YAML",
        description="The robot agent: reads one YAML laid out like the tutorial's launch file (platform:, "
                    "transforms:, sensors:) and runs each node as a supervised process: started in "
                    "dependency "
                    "order (after: nodes, wait_for: topics), respawned (respawn: true), the launch stopped "
                    "when a required: node ends, the base stopped first on Ctrl-C / SIGTERM. Node states on "
                    "zenav/<robot>/agent/robot/state. Exit 0 on Ctrl-C, 1 if a required node failed, 2 for "
                    "a bad config.")
    agent.add_arguments(p)
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    from robot_side import agent

    return agent.run(args)


if __name__ == "__main__":
    from robot_side.agent import main

    sys.exit(main())
