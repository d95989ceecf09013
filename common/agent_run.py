"""Running a launch: an agent's own session and its Supervisor, after every node's parameters are checked
(``zenav robot`` / ``zenav master``: ``robot_side.agent``, ``master_side.agent``). The launch description
itself is ``common.launch``."""

from __future__ import annotations

import os

from common.config import ConfigError
from common.launch import Launch


def _open_agent_node(agent: str, cfg):
    """The agent's own session, and the endpoint its nodes dial ("" when they join as peers: children
    "mesh", or an agent that is a client of a router). With children "agent" the agent also listens on a
    loopback port (``pick_agent_endpoint``); a port another process took since the pick is picked again."""
    from dataclasses import replace

    from common.bus import Node
    from common.child_process import pick_agent_endpoint
    from common.ports import is_address_in_use

    if cfg.children != "agent" or cfg.mode == "client":
        return Node(f"{agent}_agent", config=cfg, use_sim_time=False), ""
    for attempt in range(5):
        endpoint = pick_agent_endpoint()
        try:
            return Node(f"{agent}_agent", config=replace(cfg, local_listen=(endpoint,)), use_sim_time=False), endpoint
        except Exception as e:  # zenoh.ZError: the listener could not bind
            if attempt == 4 or not is_address_in_use(e) or endpoint.split("/", 1)[1] not in str(e):
                raise
    raise AssertionError("unreachable")


def run_agent(agent: str, launch: Launch, robot: str | None = None) -> int:
    """Run a launch under a Supervisor until Ctrl-C / SIGTERM or a required node ends.
    Robot name: ``robot`` argument, else $ZENAV_ROBOT, else the file's ``robot:``, else 'robot'.
    First every node's parameters are checked (``common.node_check``): any problem -> all of them on
    stderr and exit status 2 with nothing started; parameters without effect -> one warning block."""
    import shutil
    import sys

    from common.node_check import check_nodes, format_config_error, format_notes
    from common.runner import EXIT_CONFIG
    from common.supervisor import Supervisor
    from common.zenoh_config import DEFAULT_ROBOT, BusConfig

    robot = robot or os.environ.get("ZENAV_ROBOT") or launch.robot or DEFAULT_ROBOT
    try:  # every node's parameters, before anything starts (common.node_check)
        notes = check_nodes(launch)
    except ConfigError as e:
        print(format_config_error(agent, e), file=sys.stderr, flush=True)
        return EXIT_CONFIG
    if warning := format_notes(agent, notes):
        print(warning, file=sys.stderr, flush=True)
    cfg = BusConfig.from_env(robot=robot)
    node = None
    try:
        specs = launch.specs()
        env = dict(launch.env)
        if launch.use_sim_time:
            env.setdefault("ZENAV_USE_SIM_TIME", "1")
        node, endpoint = _open_agent_node(agent, cfg)
        s = launch.supervisor
        sup = Supervisor(specs, cfg, node, agent=agent, grace=s.grace,
                         crash_loop=(s.crash_loop_deaths, s.crash_loop_window),
                         max_respawn_delay=s.max_respawn_delay, status=sys.stderr if s.status else None,
                         extra_env=env, agent_endpoint=endpoint)
        print(f"zenav {agent}: robot '{robot}', {len(specs)} nodes from {launch.source} "
              f"(states on zenav/{robot}/agent/{agent}/state)", file=sys.stderr, flush=True)
        code = sup.run()
        why = f": {sup.reason}" if sup.reason else ""
        print(f"zenav {agent}: stopped{why}", file=sys.stderr, flush=True)
        return code
    finally:
        if node is not None:
            node.close()
        if launch.generated_dir:
            shutil.rmtree(launch.generated_dir, ignore_errors=True)
