"""The kinect bus node as its own process (``python -m robot_side.kinect.node``) over the fake
libfreenect_sync (fake_freenect_sync.c), on a private loopback Zenoh bus; and ``zenav robot`` with the
shipped real-robot config pointed at the fakes (P2OS on a pty, Kinect through the fake library)."""

from __future__ import annotations

import signal
import sys

import numpy as np
import pytest
import yaml

from common.messages import CameraInfo, DepthImage, LaserScan, TFMessage
from tests.sim_e2e.conftest import REPO, Proc, Recorder, wait_until
from tests.support import free_port


def _node(tmp_path, env, params: dict, name: str = "kinect") -> Proc:
    d = tmp_path / name
    d.mkdir()
    cfg = d / "kinect.yaml"
    cfg.write_text(yaml.safe_dump(params))
    return Proc(d, [sys.executable, "-m", "robot_side.kinect.node", "--config", str(cfg)], env)


def test_node_publishes_what_the_simulated_camera_publishes(bus, fake_lib, tmp_path):
    node, env = bus
    images = Recorder(node, "camera/depth/image", DepthImage)
    infos = node.subscribe("camera/depth/camera_info", CameraInfo)
    tf_static = node.subscribe("tf_static", TFMessage)
    proc = _node(tmp_path, env, {"library": fake_lib, "depth_mode": 5, "data_skip": 1})
    try:
        wait_until(lambda: len(images) >= 16, 30, "16 depth images", alive=lambda: "" if proc.alive() else
                   f"node exited: {proc.log()}")
        img = images.msgs()[0]
        assert img.header.frame_id == "camera_depth_optical_frame"
        d = np.asarray(img.depth)
        assert d.dtype == np.float32 and d.shape == (240, 320)
        assert d[0, 50] == pytest.approx(2.0)          # the wall
        assert d[239, 150] == pytest.approx(1.0)       # the box (VGA column 300)
        assert (d[:, :4] == 0).all()                   # no reading -> 0 (VGA columns 0..7)
        info = infos.wait_first(10)
        assert (info.width, info.height, info.header.frame_id) == (320, 240, "camera_depth_optical_frame")
        assert info.fx == pytest.approx(575.8 / 2, abs=0.05) and info.cx == pytest.approx(159.75)
        edges = {(t.header.frame_id, t.child_frame_id) for t in tf_static.wait_first(10).transforms}
        assert edges == {("camera_depth_frame", "camera_depth_optical_frame")}
        # data_skip 1: every other frame of the 30 Hz stream, by the images' own stamps (the node's clock as it
        # took each frame): their arrival times bunch when a loaded machine delivers a backlog at once (35 Hz, ci179)
        times = [m.header.stamp for m in images.msgs()]
        rate = (len(times) - 1) / (times[-1] - times[0])
        assert 10.0 < rate < 20.0, rate
    finally:
        assert proc.stop() == 0, proc.log()
    assert "fake freenect: streaming device 0 depth format 5" in proc.log()   # FREENECT_DEPTH_MM
    assert "fake freenect: stopped" in proc.log()                            # freenect_sync_stop


def test_no_library_or_no_kinect_is_one_line_and_the_no_respawn_exit(bus, fake_lib, tmp_path):
    _, env = bus
    missing = _node(tmp_path, env, {"library": str(tmp_path / "libfreenect_sync.so.0.5")}, "missing")
    absent = _node(tmp_path, {**env, "FAKE_FREENECT_NO_DEVICE": "1",   # its own listen port: both run at once
                              "ZENAV_LISTEN": f"tcp/127.0.0.1:{free_port()}"}, {"library": fake_lib}, "absent")
    assert missing.proc.wait(60) == 2, missing.log()    # common.runner.EXIT_CONFIG: FAILED, not respawned
    assert absent.proc.wait(60) == 2, absent.log()
    (line,) = [ln for ln in missing.log().splitlines() if "kinect" in ln and "error" in ln]
    assert "libfreenect_sync.so.0.5" in line and "apt-get install libfreenect0.5" in line
    (line,) = [ln for ln in absent.log().splitlines() if "kinect" in ln and "error" in ln]
    assert "no Kinect found at device_id 0" in line and fake_lib in line


def test_a_kinect_that_stops_streaming_ends_the_node_for_a_respawn(bus, fake_lib, tmp_path):
    node, env = bus
    unplug = tmp_path / "unplug"
    images = Recorder(node, "camera/depth/image", DepthImage)
    proc = _node(tmp_path, {**env, "FAKE_FREENECT_UNPLUG_FILE": str(unplug)},
                 {"library": fake_lib, "frame_timeout": 0.5})
    wait_until(lambda: len(images) > 0, 30, "a depth image", alive=lambda: "" if proc.alive() else proc.log())
    unplug.write_text("hang")      # the library call never returns again
    try:
        assert proc.proc.wait(30) == 1, proc.log()
    finally:
        proc.stop()
    assert "device 0 lost (no depth frame for" in proc.log()


def test_robot_agent_with_the_real_config_publishes_scan_and_respawns_an_unplugged_kinect(bus, fake_lib,
                                                                                        robot_name, tmp_path):
    from robot_side.p2os.fake_robot import FakeP2OSRobot
    from tests.agent.conftest import Agent
    from tests.agent.test_robot_agent import States

    node, env = bus
    robot, port = FakeP2OSRobot.on_pty()
    robot.start()
    unplug = tmp_path / "unplug"
    cfg = yaml.safe_load((REPO / "robot_side/config/p3at_real.yaml").read_text())
    cfg["platform"]["p2os_driver"]["params"]["port"] = port
    kinect = cfg["sensors"]["kinect"]
    kinect["params"]["library"] = fake_lib
    kinect["env"] = {"FAKE_FREENECT_UNPLUG_FILE": str(unplug)}
    states = States(node)
    scans = Recorder(node, "scan", LaserScan)
    (tmp_path / "agent").mkdir()
    agent = Agent(tmp_path / "agent", cfg, robot_name, env)

    def dead() -> str:
        return "" if agent.proc.poll() is None else f"agent exited: {agent.stderr()}{agent.stdout()}"

    try:
        wait_until(lambda: len(scans) > 0, 60, "scan from depth_to_scan", alive=dead)
        s = scans.last()
        assert s.header.frame_id == "camera_depth_frame"
        r = np.asarray(s.ranges)
        assert np.nanmin(r) == pytest.approx(1.0, abs=0.02)   # the fake's box, 1 m ahead
        first = wait_until(lambda: states.find(node="kinect", state="RUNNING"), 30, "kinect RUNNING")
        unplug.write_text("")          # freenect_sync_get_depth returns -1 once
        wait_until(lambda: states.find(node="kinect", state="RESTARTING"), 30, "kinect RESTARTING", alive=dead)
        def rerun():
            with states.lock:
                return next((m for m in states.msgs if m.node == "kinect" and m.state == "RUNNING"
                             and m.pid != first.pid), None)

        again = wait_until(rerun, 30, "kinect RUNNING again", alive=dead)
        assert again.restarts >= 1
        n = len(scans)
        wait_until(lambda: len(scans) > n + 5, 30, "scan after the reconnect", alive=dead)
        assert not states.find(node="kinect", state="FAILED")
        agent.proc.send_signal(signal.SIGINT)
        assert agent.wait(60) == 0, agent.stderr()
    finally:
        agent.cleanup()
        robot.close()
    assert "device unplugged" in agent.stdout()
