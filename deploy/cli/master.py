"""``zenav master --config FILE`` — the master agent (costmaps, planners, move_base, SLAM, map server)."""

from __future__ import annotations

import sys


def add_parser(subparsers):
    from master_side import agent

    p = subparsers.add_parser(
        "master", help="run the master's nodes (costmaps, planners, move_base, slam) from one YAML",
        description="The master agent: runs the nodes of the nodes: section of one YAML (module, params or "
                    "config, respawn, required, after, wait_for) as supervised processes, like "
                    "`zenav robot`. "
                    "Node states on zenav/<robot>/agent/master/state.")
    agent.add_arguments(p)
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    from master_side import agent

    return agent.run(args)


if __name__ == "__main__":
    from master_side.agent import main

    sys.exit(main())
