"""Fixtures of the costmap / merged-scan end-to-end tests: the test's own Zenoh peer on a private loopback
bus and a process starter whose processes (and their children) are killed at teardown."""

from __future__ import annotations

import os

import pytest

from common.ports import free_port
from tests.costmap_e2e.costmap_e2e_rig import REPO, CmeProc


@pytest.fixture
def cme_bus(robot_name):
    from common.bus import Node
    from common.zenoh_config import BusConfig

    port = free_port()
    cfg = BusConfig(robot=robot_name, listen=(f"tcp/127.0.0.1:{port}",), multicast=False)
    node = Node("costmap_e2e_test", config=cfg, use_sim_time=False)
    env = {**os.environ, "ZENAV_ROBOT": robot_name, "ZENAV_MULTICAST": "0", "ZENAV_MODE": "peer",
           "ZENAV_CONNECT": f"tcp/127.0.0.1:{port}",
           "PYTHONPATH": str(REPO), "PYTHONUNBUFFERED": "1"}
    env.pop("ZENAV_USE_SIM_TIME", None)
    env.pop("ZENAV_ZENOH_CONFIG", None)
    yield node, env
    node.close()


@pytest.fixture
def cme_procs(tmp_path):
    started: list[CmeProc] = []

    def start(name: str, argv: list[str], env: dict) -> CmeProc:
        """Each process listens on its own loopback port (peers connect to each other by gossip)."""
        env = {**env, "ZENAV_LISTEN": f"tcp/127.0.0.1:{free_port()}"}
        p = CmeProc(name, argv, env, tmp_path / f"{name}.log")
        started.append(p)
        return p

    yield start
    for p in reversed(started):
        p.stop()
