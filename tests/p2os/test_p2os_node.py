"""The p2os bus node as its own process (``python -m robot_side.p2os.node``) against the simulated
device on a pty, on a private loopback Zenoh bus: it publishes what the simulated base publishes."""

from __future__ import annotations

import math
import os
import sys

import pytest
import yaml

from common.messages import BatteryState, BumperState, MotorState, Odometry, SonarArray, TFMessage, Twist
from robot_side.p2os import protocol as P
from robot_side.p2os.fake_robot import FakeP2OSRobot
from tests.sim_e2e.conftest import Proc, free_port, wait_until


@pytest.fixture
def bus(robot_name):
    from common.bus import Node
    from common.zenoh_config import BusConfig

    port, child_port = free_port(), free_port()
    node = Node("p2os_test", config=BusConfig(robot=robot_name, listen=(f"tcp/127.0.0.1:{port}",),
                                              multicast=False), use_sim_time=False)
    env = {**os.environ, "ZENAV_ROBOT": robot_name, "ZENAV_MULTICAST": "0", "ZENAV_MODE": "peer",
           "ZENAV_CONNECT": f"tcp/127.0.0.1:{port}", "ZENAV_LISTEN": f"tcp/127.0.0.1:{child_port}"}
    env.pop("ZENAV_USE_SIM_TIME", None)
    yield node, env
    node.close()


@pytest.fixture
def fake():
    robot, path = FakeP2OSRobot.on_pty()
    robot.start()
    yield robot, path
    robot.close()


def _node(tmp_path, env, params: dict) -> Proc:
    cfg = tmp_path / "p2os.yaml"
    cfg.write_text(yaml.safe_dump(params))
    (tmp_path / "proc").mkdir()
    return Proc(tmp_path / "proc", [sys.executable, "-m", "robot_side.p2os.node", "--config", str(cfg)], env)


def test_node_publishes_the_simulators_topics_and_drives_the_device(bus, fake, tmp_path):
    node, env = bus
    robot, path = fake
    odom = node.subscribe("odom", Odometry)
    tf = node.subscribe("tf", TFMessage)
    motor = node.subscribe("motor_state", MotorState)
    battery = node.subscribe("battery_state", BatteryState)
    bumpers = node.subscribe("bumper_state", BumperState)
    sonar = node.subscribe("sonar", SonarArray)
    robot.sonar_mm = {11: 450.0, 3: 1200.0}  # the rear's middle-right sonar and the front's middle-left
    proc = _node(tmp_path, env, {"port": path, "pulse": 1.0, "cmd_vel_timeout": 0.5, "use_sonar": True})
    try:
        o = odom.wait_first(30)
        assert o is not None, proc.log()
        assert (o.header.frame_id, o.child_frame_id) == ("odom", "base_link")
        t = tf.wait_first(10).transforms[0]
        assert (t.header.frame_id, t.child_frame_id) == ("odom", "base_link")
        m = wait_until(lambda: (x := motor.latest()) is not None and x.enabled and x, 10, "motors enabled")
        assert m.header.frame_id == "base_link"
        b = battery.wait_first(10)
        assert b.voltage == pytest.approx(12.6)
        assert 0.0 < b.percentage < 1.0
        robot.bumpers = (0b00001, 0b10000)  # the front's segment 0 and the rear's segment 4 pressed
        pressed = wait_until(lambda: (x := bumpers.latest()) is not None and any(x.rear_bumpers) and x, 10,
                             "a bumper press")
        assert pressed.front_bumpers == (True, False, False, False, False)
        assert pressed.rear_bumpers == (False, False, False, False, True)
        robot.bumpers = (0, 0)
        s = sonar.wait_first(10)
        assert s is not None and s.header.frame_id == "base_link"
        assert len(s.ranges) == 16
        assert s.ranges[11] == pytest.approx(0.45) and s.ranges[3] == pytest.approx(1.2)
        assert all(math.isinf(r) for i, r in enumerate(s.ranges) if i not in (3, 11))  # never heard from
        assert robot.sonar_on
        assert "callback failed" not in proc.log(), proc.log()  # the first SIP comes during the handshake

        cmd = node.publisher("cmd_vel")
        wait_until(lambda: cmd._pub.matching_status.matching, 10, "the node's cmd_vel subscription")

        def moving():
            cmd.publish(Twist.planar(0.2, 0.1))
            return robot.vel_mm_s == 200 and robot.rvel_deg_s == 6

        wait_until(moving, 10, "VEL 200 mm/s + RVEL 6 deg/s at the device")
        wait_until(lambda: (x := odom.latest()) and x.pose2d.x > 0.02 and x.twist.linear.x > 0.1, 10,
                   "odom following the device")
        wait_until(lambda: robot.vel_mm_s == 0, 5, "stop after the cmd_vel timeout")
        node.publisher("cmd_motor_state", reliable=True).publish(MotorState(enabled=False))
        wait_until(lambda: (x := motor.latest()) is not None and not x.enabled, 10, "motors disabled")
    finally:
        assert proc.stop() == 0, proc.log()
    assert [c for _, c, _ in robot.received][-2:] == [P.Command.STOP, P.Command.CLOSE]


def test_node_without_a_robot_exits_with_the_port_in_the_error(bus, tmp_path):
    _, env = bus
    robot, path = FakeP2OSRobot.on_pty()  # a pty nobody answers on
    try:
        proc = _node(tmp_path, env, {"port": path, "sync_timeout": 0.1, "sync_retries": 2})
        code = proc.proc.wait(30)
        assert code not in (0, None)
        assert path in proc.log()
        assert "no answer" in proc.log()
    finally:
        robot.close()


def test_shipped_real_robot_config_loads_and_bad_values_name_the_key():
    from common.config import ConfigError
    from robot_side.agent import load as load_robot
    from robot_side.p2os.node import load
    from tests.sim_e2e.conftest import REPO

    path = REPO / "robot_side/config/p3at_real.yaml"
    launch = load_robot(str(path))
    (entry,) = [e for e in launch.entries if e.opts.module == "robot_side.p2os.node"]
    p = load(yaml.safe_load(path.read_text())["platform"][entry.name]["params"], str(path))
    assert (p.port, p.baud, p.pulse, p.motors_on_start) == ("/dev/ttyUSB0", 9600, 1.0, True)
    with pytest.raises(ConfigError, match="pulse"):
        load({"pulse": 3.0}, "x.yaml")  # beyond the robot's 2 s watchdog
    with pytest.raises(ConfigError, match="prot"):
        load({"prot": "/dev/ttyUSB1"}, "x.yaml")
