"""The commands' bus helpers: which robot a command looks at, a raw session for inspecting the system,
and waiting for Ctrl-C (zenoh is imported lazily so ``zenav --help`` stays fast)."""

from __future__ import annotations

import os
import threading
import time

from common import tcp_linger


def robot_pattern(args, all_by_default: bool) -> str:
    """The robot (or ``*`` pattern) a command looks at: --robot, else $ZENAV_ROBOT, else all/'robot'."""
    robot = getattr(args, "robot", None) or os.environ.get("ZENAV_ROBOT")
    if not robot:
        robot = "*" if all_by_default else "robot"
    if "/" in robot:
        raise ValueError(f"robot name {robot!r} must not contain '/'")
    return robot


def one_robot(args, wait_s: float = 1.5) -> str:
    """The one robot a command acts on: --robot, else $ZENAV_ROBOT, else the only robot on the network
    (said on stderr); several robots and none chosen is an error listing them; none at all keeps the
    default name 'robot'. The choice is exported as ZENAV_ROBOT for this process and its children."""
    import sys

    robot = getattr(args, "robot", None) or os.environ.get("ZENAV_ROBOT")
    if robot:
        if "/" in robot or "*" in robot:
            raise ValueError(f"this command needs one robot name, not {robot!r}")
        return robot
    from common.bus import close_quietly, list_live

    session = open_session()
    try:
        robots = sorted({key.split("/")[0] for key in list_live(session, "*", "node", timeout=wait_s)})
    finally:
        close_quietly(session)
    if len(robots) > 1:
        raise ValueError(f"several robots on the network ({', '.join(robots)}): choose one with --robot")
    robot = robots[0] if robots else "robot"
    if robots:
        print(f"zenav: using robot '{robot}', the only one on the network (--robot to choose)", file=sys.stderr)
    os.environ["ZENAV_ROBOT"] = robot
    return robot


def open_session():
    """A raw Zenoh session with the bus config from the environment (no liveliness token of its own,
    so inspecting the system does not change what ``zenav nodes`` shows)."""
    from common.zenoh_config import BusConfig

    env = dict(os.environ)
    if "*" in env.get("ZENAV_ROBOT", ""):
        env.pop("ZENAV_ROBOT")
    return tcp_linger.open_session(BusConfig.from_env(env).to_zenoh())


def wait(stop: threading.Event, duration: float | None) -> None:
    """Block until ``stop`` is set, ``duration`` seconds pass (None = forever) or Ctrl-C."""
    end = None if duration is None else time.monotonic() + duration
    while not stop.is_set():
        left = 0.2 if end is None else min(0.2, end - time.monotonic())
        if left <= 0:
            return
        stop.wait(left)
