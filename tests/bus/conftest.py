"""Fixtures for bus tests (helpers in bushelp.py)."""

from __future__ import annotations

import threading
import time

import pytest
from bushelp import Child, free_port

from common.bus import Node
from common.geometry import Transform
from common.messages import Header, TransformStamped
from common.tf import TFBroadcaster
from common.zenoh_config import BusConfig


@pytest.fixture
def spawn():
    """spawn(argv, env) -> Child; every child is killed at the end of the test."""
    children: list[Child] = []

    def start(argv: list[str], env: dict[str, str]) -> Child:
        c = Child(argv, env)
        children.append(c)
        return c

    yield start
    for c in children:
        c.stop()


@pytest.fixture
def hub_port() -> int:
    return free_port()


@pytest.fixture
def node_pair(robot_name, hub_port):
    """make(name) -> Node; the first node listens on a free loopback port, the others connect to it."""
    nodes: list[Node] = []

    def make(name: str, **kw) -> Node:
        ep = (f"tcp/127.0.0.1:{hub_port}",)
        cfg = BusConfig(
            robot=robot_name, multicast=False, **({"listen": ep} if not nodes else {"connect": ep})
        )
        n = Node(name, config=cfg, **kw)
        nodes.append(n)
        return n

    yield make
    for n in reversed(nodes):
        n.close()


@pytest.fixture
def tf_feed():
    """start(node, edges): publishes (parent, child) identity transforms stamped now at 20 Hz."""
    stop, threads = threading.Event(), []

    def start(node, edges) -> None:
        tf = TFBroadcaster(node)

        def run() -> None:
            while not stop.is_set():
                now = time.time()
                tf.send([TransformStamped(Header(now, p), c, Transform()) for p, c in edges])
                stop.wait(0.05)

        threads.append(threading.Thread(target=run, daemon=True))
        threads[-1].start()

    yield start
    stop.set()
    for t in threads:
        t.join(2.0)
