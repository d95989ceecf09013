"""The shipped robot configs run with the real simulator and depth nodes and publish ``scan``."""

from __future__ import annotations

import signal

import numpy as np
import pytest

from common.messages import LaserScan
from tests.agent.conftest import REPO, wait_until
from tests.agent.test_robot_agent import States, alive


@pytest.mark.slow
@pytest.mark.parametrize(("name", "nodes"), [
    ("p3at_sim", ("sim", "Pioneer3AT_laserscan_tf", "depth_to_scan")),
    ("pioneer_lx_sim", ("sim", "base_to_laser")),
    ("p3at_sim_virtual", ("sim", "Pioneer3AT_laserscan_tf", "cloud", "virtualizer", "merger")),
])
def test_shipped_config_runs_every_node_and_publishes_scan(bus, agents, robot_name, name, nodes):
    node, env = bus
    states = States(node)
    scan = node.subscribe("scan", LaserScan)
    agent = agents(str(REPO / "robot_side/config" / f"{name}.yaml"), robot_name, env)
    msg = scan.wait_first(120)
    assert np.isfinite(np.asarray(msg.ranges)).any()
    for n in nodes:
        wait_until(lambda n=n: states.find(node=n, state="RUNNING"), 30, f"{n} RUNNING")
    pids = {p.pid for p in agent.children()}
    agent.proc.send_signal(signal.SIGINT)
    assert agent.wait(60) == 0
    assert not any(alive(p) for p in pids)
