"""Run one node as its own process: ``python -m <module> --config FILE [--section KEY]``.

A node module provides ``start(node, cfg, source) -> obj with close()``; ``node_main`` parses the
command line, reads the node's YAML mapping, opens the bus, starts the node and waits for
SIGINT / SIGTERM, then closes it. A bad config exits with status 2 (``EXIT_CONFIG``) and every problem on
stderr; the agents' supervisor does not respawn such a node. A module MAY also define
``check(cfg, source) -> list[str]`` (see ``common.node_check``) for the agents' check before any start.
"""

from __future__ import annotations

import argparse
import faulthandler
import logging
import signal
import sys
import threading
from typing import Callable

from common.config import ConfigError, read_yaml

EXIT_CONFIG = 2


def node_config(path: str | None, section: str | None) -> tuple[dict, str]:
    """The mapping for one node: the whole file, or ``section`` of it (dotted keys allowed)."""
    if not path:
        return {}, "<defaults>"
    data = read_yaml(path)
    if section:
        for part in section.split("."):
            if not isinstance(data, dict) or part not in data:
                raise ConfigError(path, section, "section not found in file")
            data = data[part]
        if data is None:
            data = {}
        if not isinstance(data, dict):
            raise ConfigError(path, section, "section must be a mapping")
    return data, path


def _config_exit(name: str, e: ConfigError) -> None:
    """Report every problem on stderr and end the process with EXIT_CONFIG (SystemExit, so a module
    whose ``__main__`` ignores node_main's return value still exits 2 and is not respawned)."""
    print(f"zenav {name}: config error: {e}", file=sys.stderr, flush=True)
    raise SystemExit(EXIT_CONFIG)


def node_main(default_name: str, start: Callable, argv: list[str] | None = None) -> int:
    """Run a node until SIGINT / SIGTERM; returns 0 or the node's own ``exit_code``. A configuration
    error raises SystemExit(EXIT_CONFIG) (the supervisor then marks the node FAILED, no respawn)."""
    ap = argparse.ArgumentParser(prog=f"zenav node {default_name}",
                                 description=f"Run the zenav '{default_name}' node on the bus.")
    ap.add_argument("--config", help="YAML file with this node's parameters")
    ap.add_argument("--section", help="key of this node's mapping inside the file (dots for nesting)")
    ap.add_argument("--robot", help="robot name (key prefix zenav/<robot>/...); default $ZENAV_ROBOT")
    ap.add_argument("--name", default=default_name, help="node name (liveliness, logs)")
    ap.add_argument("-v", "--verbose", action="store_true")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.DEBUG if args.verbose else logging.INFO,
                        format=f"%(asctime)s {args.name} %(levelname)s %(message)s")
    try:
        cfg, source = node_config(args.config, args.section)
    except ConfigError as e:
        _config_exit(args.name, e)

    from common.bus import Node  # imported late: config errors are reported without opening zenoh

    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    # a node alive but silent (no status, no log, no service answer): `kill -USR1 <pid>` (the pid is in the
    # agent's status table) writes every thread's stack to its log, and the node goes on
    faulthandler.register(signal.SIGUSR1, all_threads=True)
    node = Node(args.name, robot=args.robot)
    try:
        try:
            handle = start(node, cfg, source)
        except ConfigError as e:
            _config_exit(args.name, e)
        # A node can end its own process (e.g. a driver that lost its serial port, so the agent's
        # respawn reconnects it) by setting ``handle.finished`` (an Event) and ``handle.exit_code``.
        finished = getattr(handle, "finished", None)
        while not stop.wait(0.5):
            if finished is not None and finished.is_set():
                break
        if handle is not None and hasattr(handle, "close"):
            handle.close()
        if finished is not None and finished.is_set():
            return int(getattr(handle, "exit_code", 1))
    finally:
        node.close()
    return 0


def run_main(default_name: str, start: Callable) -> None:
    sys.exit(node_main(default_name, start))
