"""The s300 bus node as its own process (``python -m robot_side.lasers.s300_node``) against the fake
scanner on a pty, on a private loopback Zenoh bus; and ``zenav robot`` with the shipped real Pioneer LX
config pointed at the fakes: scan and odom on the bus, an unplugged scanner respawned and reconnected."""

from __future__ import annotations

import math
import os
import shutil
import sys

import numpy as np
import pytest
import yaml

from common.messages import LaserScan, Odometry
from robot_side.lasers.fake_s300 import FakeS300
from robot_side.p2os.fake_robot import FakeP2OSRobot
from tests.sim_e2e.conftest import REPO, Proc, free_port, wait_until

CONFIG = REPO / "robot_side/config/pioneer_lx_real.yaml"
FRONT = 270  # beam straight ahead of 541 over 270 degrees


@pytest.fixture
def bus(robot_name):
    from common.bus import Node
    from common.zenoh_config import BusConfig

    port, child_port = free_port(), free_port()
    node = Node("s300_test", config=BusConfig(robot=robot_name, listen=(f"tcp/127.0.0.1:{port}",),
                                              multicast=False), use_sim_time=False)
    env = {**os.environ, "ZENAV_ROBOT": robot_name, "ZENAV_MULTICAST": "0", "ZENAV_MODE": "peer",
           "ZENAV_CONNECT": f"tcp/127.0.0.1:{port}", "ZENAV_LISTEN": f"tcp/127.0.0.1:{child_port}",
           "PYTHONPATH": str(REPO)}
    env.pop("ZENAV_USE_SIM_TIME", None)
    yield node, env
    node.close()


@pytest.fixture
def fakes():
    made = []

    def make(cls=FakeS300, **kw):
        dev, path = cls.on_pty(**kw)
        dev.start()
        made.append(dev)
        return dev, path

    yield make
    for dev in made:
        dev.close()


def _front(sub, want: float, timeout: float, alive=None) -> LaserScan:
    return wait_until(lambda: (s := sub.latest()) is not None and abs(s.ranges[FRONT] - want) < 0.01 and s,
                      timeout, f"a scan with {want} m straight ahead", alive=alive)


def test_node_publishes_the_scan_and_exits_nonzero_when_the_scanner_is_unplugged(bus, fakes, tmp_path):
    node, env = bus
    fake, path = fakes(room=(-2.0, 4.0, -3.0, math.inf))
    scans = node.subscribe("scan", LaserScan)
    cfg = tmp_path / "s300.yaml"
    cfg.write_text(yaml.safe_dump({"port": path, "frame_id": "laser"}))
    (tmp_path / "proc").mkdir()
    proc = Proc(tmp_path / "proc", [sys.executable, "-m", "robot_side.lasers.s300_node", "--config", str(cfg)],
                env)
    try:
        s = _front(scans, 4.0, 30, alive=lambda: proc.proc.poll() is not None and proc.log())
        assert (s.header.frame_id, len(s.ranges), s.ranges.dtype) == ("laser", 541, np.float32)
        assert s.angle_min == pytest.approx(-2.356194) and s.angle_max == pytest.approx(2.356194)
        truth = fake.true_ranges()
        hit = np.isfinite(truth)
        np.testing.assert_allclose(s.ranges[hit], truth[hit], atol=0.0051)
        assert np.all(np.isposinf(s.ranges[~hit]))
        fake.unplug()
        code = proc.proc.wait(30)
        assert code not in (0, None), proc.log()
        assert "failed" in proc.log() and path in proc.log()
    finally:
        proc.stop()


def test_zenav_robot_with_the_real_lx_config_on_the_fakes_respawns_an_unplugged_scanner(
        bus, fakes, tmp_path, robot_name):
    node, env = bus
    _, base_path = fakes(FakeP2OSRobot)
    link = str(tmp_path / "ttyS300")
    scanner, _ = fakes(link=link, room=(-2.0, 4.0, -3.0, 3.0))
    cfg = yaml.safe_load(CONFIG.read_text())
    cfg["platform"]["p2os_driver"]["params"]["port"] = base_path
    cfg["sensors"]["s300"]["params"]["port"] = link
    path = tmp_path / "pioneer_lx_real.yaml"
    path.write_text(yaml.safe_dump(cfg, sort_keys=False))
    scans, odom = node.subscribe("scan", LaserScan), node.subscribe("odom", Odometry)
    exe = shutil.which("zenav")
    argv = [exe] if exe else [sys.executable, "-m", "deploy.cli"]
    (tmp_path / "agent").mkdir()
    agent = Proc(tmp_path / "agent", [*argv, "robot", "--config", str(path), "--robot", robot_name], env)
    try:
        def dead():
            return agent.proc.poll() is not None and f"agent exited: {agent.log()}"

        _front(scans, 4.0, 60, alive=dead)
        o = wait_until(odom.latest, 30, "odom from the p2os driver", alive=dead)
        assert (o.header.frame_id, o.child_frame_id) == ("odom", "base_link")
        scanner.unplug()
        fakes(link=link, room=(-1.0, 1.5, -1.0, 1.0))  # a new scanner on the same device link
        _front(scans, 1.5, 60, alive=dead)
        assert "s300" in agent.log()
    finally:
        assert agent.stop() == 0, agent.log()

