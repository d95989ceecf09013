"""The hokuyo node as its own process (``python -m robot_side.lasers.hokuyo_node``) and through
``zenav robot`` (the shipped example config), against the simulated device, on a private loopback bus."""

from __future__ import annotations

import math
import shutil
import signal
import sys
import time

import pytest
import yaml

from common.messages import CollisionMonitorState, LaserScan
from robot_side.lasers.fake_hokuyo import FakeHokuyo
from tests.sim_e2e.conftest import REPO, Proc, Recorder, bus, procs, wait_until  # noqa: F401

EXAMPLE = REPO / "robot_side/config/hokuyo_example.yaml"


def zenav() -> list[str]:
    exe = shutil.which("zenav")
    return [exe] if exe else [sys.executable, "-m", "deploy.cli"]


@pytest.fixture
def fakes():
    made: list[FakeHokuyo] = []

    def make(tcp: bool = False, **kw):
        fake, where = FakeHokuyo.on_tcp(**kw) if tcp else FakeHokuyo.on_pty(**kw)
        made.append(fake.start())
        return fake, where

    yield make
    for f in made:
        f.close()


def _node(procs, env, tmp_path, params: dict, n: int = 0) -> Proc:  # noqa: F811
    cfg = tmp_path / f"hokuyo{n}.yaml"
    cfg.write_text(yaml.safe_dump(params))
    return procs([sys.executable, "-m", "robot_side.lasers.hokuyo_node", "--config", str(cfg)], env)


def test_node_publishes_the_scan_exits_nonzero_when_unplugged_and_a_new_process_reconnects(
        bus, procs, fakes, tmp_path):  # noqa: F811
    node, env = bus
    link = str(tmp_path / "ttyHOKUYO")
    fake, _ = fakes(link=link)
    scans = Recorder(node, "front/scan", LaserScan)
    params = {"serial_port": link, "topic": "front/scan", "frame_id": "front_laser", "angle_min": -1.5,
              "angle_max": 1.5, "scan_timeout": 0.5}
    first = _node(procs, env, tmp_path, params)
    msg = wait_until(lambda: scans.last(), 30, "a scan on front/scan", alive=lambda: "" if first.alive()
                     else f"node exited: {first.log()}")
    assert msg.header.frame_id == "front_laser" and msg.ranges.dtype.name == "float32"
    assert -1.5 <= msg.angle_min < -1.5 + msg.angle_increment and msg.angle_max <= 1.5
    assert math.isinf(max(msg.ranges)) and 1.0 < float(min(msg.ranges)) < 1.6  # the room, the glass pane
    fake.unplug()
    code = first.proc.wait(20)
    assert code not in (0, None), first.log()
    assert "exiting so the agent can reconnect" in first.log()
    fakes(link=link)  # the sensor plugged in again (a new device behind the same name)
    n = len(scans)
    second = _node(procs, env, tmp_path, params, 1)
    wait_until(lambda: len(scans) >= n + 3, 30, "scans from the second process",
               alive=lambda: "" if second.alive() else f"node exited: {second.log()}")
    assert second.stop() == 0, second.log()


def test_zenav_robot_with_the_example_config_streams_scan_and_respawns_after_an_unplug(
        bus, procs, fakes, tmp_path, robot_name):  # noqa: F811
    node, env = bus
    fake, (host, port) = fakes(tcp=True, model="UST-10LX")
    cfg = yaml.safe_load(EXAMPLE.read_text())
    del cfg["platform"]  # no base here: the collision monitor starts after the laser instead
    cfg["safety"]["collision_monitor"]["after"] = ["hokuyo"]
    cfg["sensors"]["hokuyo"]["params"].update(ip_address=host, ip_port=port, scan_timeout=0.5)
    path = tmp_path / "robot.yaml"
    path.write_text(yaml.safe_dump(cfg, sort_keys=False))
    scans = Recorder(node, "scan", LaserScan)
    state = Recorder(node, "collision_monitor/state", CollisionMonitorState)
    agent = procs([*zenav(), "robot", "--config", str(path), "--robot", robot_name], env)
    alive = lambda: "" if agent.alive() else f"agent exited: {agent.log()}"  # noqa: E731
    msg = wait_until(lambda: scans.last(), 60, "scan through zenav robot", alive=alive)
    assert msg.header.frame_id == "laser" and len(msg.ranges) > 600
    wait_until(lambda: state.last() and state.last().action != "no_data", 30, "the monitor reading scan",
               alive=alive)
    fake.unplug()
    new, _ = fakes(tcp=True, port=port, model="UST-10LX")  # a new sensor at the same address
    wait_until(lambda: new.scans_sent >= 3, 60, "the agent's respawned node streaming from the new sensor",
               alive=alive)
    n = len(scans)
    wait_until(lambda: len(scans) >= n + 3, 30, "its scans on the bus", alive=alive)


@pytest.mark.parametrize("link", ["pty", "tcp"])
def test_a_node_paused_longer_than_scan_timeout_keeps_its_laser_when_the_scans_waited_in_the_port(
        bus, procs, fakes, tmp_path, link):  # noqa: F811
    """A loaded robot PC may not run the node for a while, the device streaming on meanwhile: the scans wait
    in the port. The node reads what waits before it judges the laser silent (it had read one byte, judged,
    and exited "so the agent can reconnect", with a dozen whole scans in the port)."""
    node, env = bus
    params: dict = {"topic": "front/scan", "frame_id": "front_laser", "scan_timeout": 0.5}
    if link == "tcp":
        fake, (host, port) = fakes(tcp=True, model="UST-10LX")
        params.update(ip_address=host, ip_port=port)
    else:
        fake, _ = fakes(link=str(tmp_path / "ttyHOKUYO"))
        params.update(serial_port=str(tmp_path / "ttyHOKUYO"))
    scans = Recorder(node, "front/scan", LaserScan)
    proc = _node(procs, env, tmp_path, params)
    alive = lambda: "" if proc.alive() else f"node exited: {proc.log()}"  # noqa: E731
    wait_until(lambda: len(scans) >= 3, 30, "scans on front/scan", alive=alive)
    proc.proc.send_signal(signal.SIGSTOP)  # the node gets no CPU; the device goes on streaming
    try:
        sent, stopped = fake.scans_sent, time.monotonic()  # a 1 s pause: twice scan_timeout
        wait_until(lambda: fake.scans_sent >= sent + 3 and time.monotonic() - stopped >= 1.0, 30,
                   "scans waiting in the port and 1 s passed")
    finally:
        proc.proc.send_signal(signal.SIGCONT)
    n = len(scans)
    wait_until(lambda: len(scans) >= n + 15, 30, "scans after the pause", alive=alive)
    assert "no scan from the Hokuyo" not in proc.log()
    assert proc.stop() == 0, proc.log()
