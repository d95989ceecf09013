"""Issue 3 acceptance through the robot agent: ``zenav robot --config robot_side/config/p3at_sim.yaml``
as a subprocess (simulator + tutorial static transform + depth_to_scan), driven from a separate peer."""

from __future__ import annotations

import shutil
import sys
import threading

import numpy as np
import pytest
import zenoh

from common.codec import decode
from common.messages import CollisionMonitorState, LaserScan, TFMessage
from common.tf import TFListener
from robot_side.sim.base import BaseParams
from tests.sim_e2e.conftest import REPO, Recorder, open_world, wait_until
from tests.sim_e2e.e2e_checks import (
    FRONT,
    Rig,
    check_odom_tf_ground_truth_agree,
    check_stale_cmd_vel_stops,
    check_wall_collision,
)

CONFIG = REPO / "robot_side" / "config" / "p3at_sim.yaml"
WALL_X = 2.0


def zenav() -> list[str]:
    exe = shutil.which("zenav")
    return [exe] if exe else [sys.executable, "-m", "deploy.cli"]


@pytest.fixture
def robot(bus, procs, tmp_path, robot_name):
    """start(wall_x=None) -> Rig on `zenav robot --config p3at_sim.yaml --world <tmp> --start 0 0 0`."""
    node, env = bus

    def start(wall_x: float | None = None, speed: float = 2.0, cmd_topic: str = "cmd_vel") -> Rig:
        world = open_world(tmp_path, wall_x=wall_x)
        proc = procs([*zenav(), "robot", "--config", str(CONFIG), "--world", str(world),
                      "--start", "0", "0", "0", "--speed", str(speed), "--robot", robot_name], env)
        rig = Rig(node, proc, timeout=120.0, cmd_topic=cmd_topic)
        state = Recorder(node, "collision_monitor/state", CollisionMonitorState)
        # the collision monitor holds the robot until the depth camera's scan flows: no data, no motion
        wait_until(lambda: state.msgs() and state.msgs()[-1].action != "no_data", 120, "scan at the monitor")
        return rig

    return start


def test_agent_odom_tf_and_ground_truth_agree_within_the_error_model(bus, robot):
    node, _ = bus
    rig = robot()
    check_odom_tf_ground_truth_agree(rig, TFListener(node), BaseParams())


def test_agent_stale_cmd_vel_stops_the_robot_within_the_timeout(bus, robot):
    # the base's own timeout, so the command goes where the base listens (the collision monitor, which
    # zeroes a stale command after the same 0.25 s, holds the robot while a scan is late: not this test)
    check_stale_cmd_vel_stops(robot(speed=1.0, cmd_topic="safety/cmd_vel"), BaseParams())


def test_agent_driving_into_a_wall_behind_the_collision_monitor_reports_a_collision_and_stops(bus, robot):
    # safety/cmd_vel is what the base listens to: commands there bypass the collision monitor
    check_wall_collision(robot(wall_x=WALL_X, cmd_topic="safety/cmd_vel"), wall_x=WALL_X, resolution=0.05)


def test_agent_commanded_at_a_wall_through_cmd_vel_is_stopped_short_by_its_collision_monitor(bus, robot):
    node, _ = bus
    state = Recorder(node, "collision_monitor/state", CollisionMonitorState)
    rig = robot(wall_x=WALL_X, speed=1.0)
    rig.drive([(8.0, 0.5, 0.0)])  # the master keeps asking for 0.5 m/s into the wall
    front = rig.gt.last().pose2d.x + FRONT
    assert len(rig.collision) == 0, f"collided: {rig.collision.last()}"
    assert WALL_X - 0.2 < front < WALL_X, f"front stopped at {front:.3f} m, wall at {WALL_X} m"
    actions = {m.action for m in state.msgs()}
    assert actions & {"approach", "stop"}, actions
    assert "collision monitor: " in rig.proc.log()


def _publishers(session: zenoh.Session, key: str, samples: int) -> dict[str, set[str]]:
    """child frame -> names of the nodes that published it on ``key``: every latched reply, then live
    samples until ``samples`` of them arrived."""
    seen: dict[str, set[str]] = {}
    lock = threading.Lock()
    count = [0]

    def add(payload, attachment) -> None:
        who = attachment.to_bytes().decode() if attachment is not None else "?"
        with lock:
            count[0] += 1
            for ts in decode(payload.to_bytes(), TFMessage).transforms:
                seen.setdefault(ts.child_frame_id, set()).add(who)

    sub = session.declare_subscriber(key, lambda s: add(s.payload, s.attachment))
    for reply in session.get(key, target=zenoh.QueryTarget.ALL, consolidation=zenoh.ConsolidationMode.NONE,
                             timeout=5.0):
        if reply.ok is not None:
            add(reply.ok.payload, reply.ok.attachment)
    wait_until(lambda: count[0] >= samples, 30, f"{samples} messages on {key}")
    sub.undeclare()
    return seen


def test_p3at_config_has_one_publisher_per_tf_edge_and_a_level_kinect(bus, robot):
    node, _ = bus
    scan = Recorder(node, "scan", LaserScan)
    tf = TFListener(node)
    robot()
    # the whole chain: tutorial static transform (base_link -> camera_link) + the sim's driver frames
    t = tf.buffer.lookup("base_link", "camera_depth_optical_frame", timeout=60.0).transform
    got = t.apply(np.array([[0, 0, 0], [0, 0, 1], [1, 0, 0]], float))
    assert np.allclose(got, [[0.1, 0, 0.35], [1.1, 0, 0.35], [0.1, -1, 0.35]], atol=1e-6), got
    assert tf.buffer.parent("camera_link") == "base_link"
    assert tf.buffer.parent("camera_depth_frame") == "camera_link"
    static = _publishers(node.session, node.key("tf_static"), 2)  # two latched publishers
    stream = _publishers(node.session, node.key("tf"), 50)
    assert static.get("camera_link") == {"Pioneer3AT_laserscan_tf"}, static
    for child in ("camera_depth_frame", "camera_depth_optical_frame"):
        assert static.get(child) == {"sim"}, static
    assert stream.get("base_link") == {"sim"}, stream
    assert not set(static) & set(stream), "an edge is both static and streamed"
    # depth_to_scan's scan (camera_depth_frame) resolves to a level plane at the Kinect height
    s = wait_until(scan.last, 60, "scan from depth_to_scan")
    d = tf.buffer.lookup("base_link", s.header.frame_id, timeout=10.0).transform
    assert np.allclose(d.apply(np.array([[1.0, 0, 0], [0, 1.0, 0]])), [[1.1, 0, 0.35], [0.1, 1, 0.35]],
                       atol=1e-6)
