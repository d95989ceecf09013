"""TF over real Zenoh sessions on loopback: broadcaster -> listener, latched static, `zenav tf` commands."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from common.bus import Node
from common.config import read_yaml
from common.geometry import Pose2D
from common.messages import Header, TransformStamped
from common.static_tf_node import start as start_static_node
from common.tf import StaticTFBroadcaster, TFBroadcaster, TFListener, parse_static_args

DEADLINE = 15.0  # generous: CI machines are shared


def odom_ts(stamp: float, x: float) -> TransformStamped:
    return TransformStamped(Header(stamp, "odom"), "base_link", Pose2D(x, 0.5, 0.25).to_transform())


def test_broadcaster_to_listener_in_another_session(loopback):
    cfg_a, cfg_b = loopback
    with Node("odometry", config=cfg_a) as a, Node("navigator", config=cfg_b) as b:
        br, tf = TFBroadcaster(a), TFListener(b)
        deadline = time.monotonic() + DEADLINE
        k = 0
        # Streamed topic: publish until the listener has it (messages before the link is up are lost).
        while not tf.buffer.can_transform("odom", "base_link", 0.0, timeout=0.05):
            assert time.monotonic() < deadline, "no transform received"
            br.send(odom_ts(100.0 + k, float(k)))
            k += 1
        br.send([odom_ts(200.0, 1.0), odom_ts(201.0, 3.0)])
        got = tf.buffer.lookup("odom", "base_link", 200.5, timeout=DEADLINE)
        assert got.transform.translation.x == pytest.approx(2.0)
        p = tf.buffer.lookup_pose2d("odom", "base_link", 201.0)
        assert (p.x, p.y, p.theta) == pytest.approx((3.0, 0.5, 0.25))
        (edge,) = tf.buffer.edges()
        assert (edge.parent, edge.child, edge.publisher) == ("odom", "base_link", "odometry")
        assert not edge.static
        tf.close()


def test_static_transforms_reach_a_late_listener_from_every_static_publisher(loopback, shared_dir):
    cfg_a, cfg_b = loopback
    path = shared_dir / "reference" / "p3at" / "static_transforms.yaml"
    with Node("static_transform_publisher", config=cfg_a) as a, \
            Node("laser_driver", config=cfg_a, session=a.session) as a2:
        handle = start_static_node(a, read_yaml(path), str(path))
        laser = StaticTFBroadcaster(a2)
        laser.send(parse_static_args("0.2 0 0.1 0 0 0 base_link laser")[0])
        laser.send(parse_static_args("0 0 0 0 0 0 base_link base_footprint")[0])  # both kept, one message
        # The listener starts after everything was published: only the latched copies can reach it.
        with Node("late", config=cfg_b) as b:
            tf = TFListener(b)
            cam = tf.buffer.lookup("laser", "camera_link", timeout=DEADLINE)
            want = np.linalg.inv(parse_static_args("0.2 0 0.1 0 0 0 b l")[0].transform.as_matrix()) @ \
                parse_static_args("0.1 0 0.35 0 pi/2 pi/2 b c")[0].transform.as_matrix()
            np.testing.assert_allclose(cam.transform.as_matrix(), want, atol=1e-12)
            assert tf.buffer.can_transform("base_footprint", "camera_link", timeout=DEADLINE)
            edges = {e.child: e for e in tf.buffer.edges()}
            assert edges["camera_link"].publisher == "static_transform_publisher"
            assert edges["laser"].publisher == edges["base_footprint"].publisher == "laser_driver"
            assert all(e.static for e in edges.values())
            tf.close()
        handle.close()


def test_static_publisher_joining_after_the_listener_is_heard(loopback):
    cfg_a, cfg_b = loopback
    with Node("navigator", config=cfg_a) as b:  # the listener's side listens; the publisher joins later
        tf = TFListener(b)
        with Node("static_transform_publisher", config=cfg_b) as a:
            StaticTFBroadcaster(a).send(parse_static_args("0 0 0.5 0 0 0 base_link laser")[0])
            got = tf.buffer.lookup("base_link", "laser", timeout=DEADLINE)
            assert got.transform.translation.z == 0.5
        tf.close()


def test_a_static_only_listener_gets_the_mounts_and_none_of_the_stream(loopback):
    """The simulator's listener: tf_static alone (the tf stream at a simulator's rate costs every listener)."""
    cfg_a, cfg_b = loopback
    with Node("odometry", config=cfg_a) as a, Node("sim", config=cfg_b) as b:
        static_tf, full = TFListener(b, static_only=True), TFListener(b)
        StaticTFBroadcaster(a).send(parse_static_args("0 0 0.5 0 0 0 base_link laser")[0])
        br, k = TFBroadcaster(a), 0
        deadline = time.monotonic() + DEADLINE
        while full.received < 5 or not static_tf.buffer.can_transform("base_link", "laser"):
            assert time.monotonic() < deadline, (full.received, static_tf.received)
            br.send(odom_ts(100.0 + k, float(k)))
            k += 1
            time.sleep(0.01)
        assert static_tf.buffer.lookup("base_link", "laser").transform.translation.z == 0.5
        assert not static_tf.buffer.can_transform("odom", "base_link"), "the tf stream reached a static-only listener"
        assert static_tf.stats()[0][0] == "tf_static"
        assert full.stats()[0][0] == "tf+tf_static"
        static_tf.close()
        full.close()


@pytest.fixture
def robot_publishing(loopback, shared_dir, monkeypatch):
    """A 'robot' publishing map->odom, odom->base_link at 20 Hz and the p3at static transform;
    the ZENAV_* environment set so that CLI commands connect to it."""
    cfg_a, cfg_b = loopback
    for k, v in cfg_b.to_env().items():
        monkeypatch.setenv(k, v)
    path = shared_dir / "reference" / "p3at" / "static_transforms.yaml"
    with Node("slam", config=cfg_a) as slam, Node("odometry", config=cfg_a, session=slam.session) as odo:
        handle = start_static_node(odo, read_yaml(path), str(path))
        br_map, br_odom = TFBroadcaster(slam), TFBroadcaster(odo)

        def tick() -> None:
            now = odo.clock.now()
            br_map.send(TransformStamped(Header(now, "map"), "odom", Pose2D(1.0, 0.0, 0.0).to_transform()))
            br_odom.send(TransformStamped(Header(now, "odom"), "base_link", Pose2D(0.5, 0, 0).to_transform()))

        timer = odo.timer(0.05, tick)
        yield cfg_b.robot
        timer.cancel()
        handle.close()


def _run_cli(argv: list[str]) -> int:
    from deploy.cli import apply_bus_env, build_parser

    args = build_parser(["deploy.cli.tf"]).parse_args(argv)
    apply_bus_env(args)
    return args.func(args)


def test_tf_tree_command_prints_tree_and_writes_dot(robot_publishing, tmp_path, capsys):
    dot = tmp_path / "frames.dot"
    rc = _run_cli(["tf", "tree", "--robot", robot_publishing, "--duration", "3", "--dot", str(dot)])
    out = capsys.readouterr().out
    assert rc == 0, out
    text = dot.read_text()
    assert text.startswith("digraph G {")
    for parent, child, who in (("map", "odom", "slam"), ("odom", "base_link", "odometry"),
                               ("base_link", "camera_link", "odometry")):
        line = next(x for x in text.splitlines() if x.startswith(f'"{parent}" -> "{child}"'))
        assert f"Broadcaster: {who}" in line
    assert "Average rate: static" in text
    lines = out.splitlines()
    assert "map" in lines
    indent = {ln.split("── ")[1].split()[0]: ln.index("── ") for ln in lines if "── " in ln}
    assert indent["odom"] < indent["base_link"] < indent["camera_link"]
    rate = float(next(ln for ln in lines if "── odom " in ln).split("slam, ")[1].split(" Hz")[0])
    assert 5.0 < rate < 40.0  # published at 20 Hz


def test_tf_echo_prints_translation_and_rpy(robot_publishing, capsys):
    rc = _run_cli(["tf", "echo", "base_link", "camera_link", "-n", "1", "--robot", robot_publishing])
    out = capsys.readouterr().out
    assert rc == 0, out
    assert "- Translation: [0.100, 0.000, 0.350]" in out
    assert "in Quaternion [0.500, 0.500, -0.500, 0.500]" in out
    # yaw 0, pitch pi/2, roll pi/2 recovered despite the gimbal lock at pitch pi/2
    assert f"in RPY (radian) [{math.pi / 2:.3f}, {math.pi / 2:.3f}, 0.000]" in out
