"""`zenav record` as a subprocess on a private loopback bus, fed by publishers in this process: stopped
by --duration (and by SIGTERM), the file read back: no gap in any stream, contents equal to what was
published, latched topics fetched once per publisher, costmaps throttled, times as documented."""

from __future__ import annotations

import re
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest
from mcap.reader import make_reader
from test_mcap_io import assert_ros1_equal

from common import messages as m
from common.bus import Node
from common.geometry import Pose2D, Quaternion, Transform, Vector3
from common.zenoh_config import BusConfig
from deploy.logs.mcap_io import read_records
from deploy.stack.process_group import checkout_env
from tests.support import free_port, wait_until

STREAMS = ("scan", "odom", "tf", "cmd_vel", "move_base/status", "global_costmap/costmap")


def _msg(topic: str, i: int, stamp: float):
    h = m.Header(stamp, "odom")
    if topic == "scan":
        return m.LaserScan(m.Header(stamp, "laser"), -1.5, 1.5, 0.01, 0.0, 0.1, 0.05, 20.0,
                           np.full(301, i, np.float32), np.zeros(301, np.float32))
    if topic == "odom":
        return m.Odometry(h, "base_link", Transform(Vector3(float(i), 1.0, 0.0), Quaternion.from_yaw(0.1)),
                          m.Twist.planar(0.3, 0.1))
    if topic == "tf":
        return m.TFMessage((m.TransformStamped(h, "base_link", Transform(Vector3(float(i), 0.0, 0.0))),))
    if topic == "cmd_vel":
        return m.Twist.planar(i * 1e-3, 0.2)
    if topic == "move_base/status":
        return m.MoveBaseStatus(h, "g", 1, "CONTROLLING", distance_to_goal_m=float(i))
    data = np.zeros((20, 30), np.uint8)
    data[0, :4] = (0, 253, 254, 255)
    data[1, :] = i % 256
    return m.Costmap(m.Header(stamp, "map"), 0.05, Pose2D(float(i), -1.0, 0.0), data)  # costs are lossy in ROS1


def _seq(topic: str, msg) -> int:
    return {"scan": lambda: int(msg.ranges[0]), "odom": lambda: int(msg.pose.translation.x),
            "tf": lambda: int(msg.transforms[0].transform.translation.x),
            "cmd_vel": lambda: int(round(msg.linear.x * 1e3)), "move_base/status": lambda: int(msg.distance_to_goal_m),
            "global_costmap/costmap": lambda: int(msg.origin.x)}[topic]()


@pytest.fixture
def bus(robot_name):
    """Two nodes of a private loopback bus: ``hub`` listens on a free port, ``other`` connects to it."""
    ep = f"tcp/127.0.0.1:{free_port()}"
    hub = Node("pubs", config=BusConfig(robot=robot_name, multicast=False, listen=(ep,)))
    other = Node("statics", config=BusConfig(robot=robot_name, multicast=False, connect=(ep,)))
    yield robot_name, ep, hub, other
    other.close()
    hub.close()


def _record(tmp_path, robot, ep, *args) -> tuple:
    out = tmp_path / "rec.mcap"
    env = checkout_env(drop_zenav=True)
    env.update(ZENAV_ROBOT=robot, ZENAV_MULTICAST="0", ZENAV_CONNECT=ep)
    proc = subprocess.Popen([sys.executable, "-m", "deploy.cli", "record", str(out), *args], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    return out, proc


def test_record_by_duration_reads_back_every_message_in_order(tmp_path, bus):
    robot, ep, hub, other = bus
    grid = m.OccupancyGrid(m.Header(time.time(), "map"), 0.05, Pose2D(-2.0, -3.0, 0.5),
                           np.arange(-1, 99, dtype=np.int8).reshape(10, 10))
    hub.publisher("map", latched=True).publish(grid)
    statics = {"laser": hub, "camera_link": other}
    for child, node in statics.items():
        node.publisher("tf_static", latched=True).publish(m.TFMessage(
            (m.TransformStamped(m.Header(0.0, "base_link"), child, Transform(Vector3(0.2, 0, 0.3))),)))
    pubs = {t: hub.publisher(t, reliable=True) for t in STREAMS}  # blocking: no drop at the sender
    published: dict[str, list] = {t: [] for t in STREAMS}
    out, proc = _record(tmp_path, robot, ep, "--topics", ",".join([*STREAMS, "map", "tf_static"]),
                        "--duration", "4", "--progress", "1")
    stop = threading.Event()

    def publish() -> None:
        i = 0
        while not stop.is_set():
            for t in STREAMS:
                msg = _msg(t, i, time.time())
                published[t].append(msg)
                pubs[t].publish(msg)
            i += 1
            stop.wait(0.025)

    th = threading.Thread(target=publish, daemon=True)
    th.start()
    try:
        _, err = proc.communicate(timeout=90)
    finally:
        stop.set()
        th.join()
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, err
    assert err.count("msgs") >= 3, err  # progress lines every second, then the summary
    assert f"wrote {out}" in err

    records = list(read_records(out))
    by_topic: dict[str, list] = {}
    for r in records:
        by_topic.setdefault(r.topic, []).append(r)
    assert [r.stamp for r in records] == sorted(r.stamp for r in records)
    for t in ("scan", "odom", "tf", "cmd_vel", "move_base/status"):
        seqs = [_seq(t, r.msg) for r in by_topic[t]]
        assert len(seqs) >= 40, (t, len(seqs))  # ~4 s at 40 Hz
        assert seqs == list(range(seqs[0], seqs[0] + len(seqs))), f"{t}: gap or reorder in {seqs}"
        for r, s in zip(by_topic[t], seqs):
            want = published[t][s]
            if t == "move_base/status":
                assert m.msg_equal(r.msg, want)
            else:
                assert_ros1_equal(r.msg, want, t)
    costmaps = by_topic["global_costmap/costmap"]
    assert 2 <= len(costmaps) <= 2 * 4 + 3, len(costmaps)  # throttled to 2 Hz by default
    for r in costmaps:
        assert_ros1_equal(r.msg, published["global_costmap/costmap"][_seq("global_costmap/costmap", r.msg)])
    assert len(by_topic["map"]) == 1
    assert_ros1_equal(by_topic["map"][0].msg, grid)
    assert sorted(r.msg.transforms[0].child_frame_id for r in by_topic["tf_static"]) == sorted(statics)

    # log time = stamp for stamped messages, the receive time (= publish_time) for cmd_vel
    with open(out, "rb") as f:
        rows = [(c.topic, msg.log_time, msg.publish_time) for _, c, msg in make_reader(f).iter_messages()]
    for topic, log_ns, pub_ns in rows:
        if topic == "/cmd_vel":
            assert log_ns == pub_ns
        elif topic in ("/scan", "/odom"):
            assert 0 <= pub_ns - log_ns < 2e9, (topic, pub_ns - log_ns)


def test_all_topics_until_sigterm_then_a_complete_file_and_bad_paths_exit_2(tmp_path, bus):
    robot, ep, hub, other = bus
    scan = hub.publisher("scan")
    grid = m.OccupancyGrid(m.Header(time.time(), "map"), 0.1, Pose2D(), np.zeros((3, 4), np.int8))
    other.publisher("map", latched=True).publish(grid)
    other.service("ping", lambda req: req)  # services are no topics
    out, proc = _record(tmp_path, robot, ep, "--all", "--progress", "0.2")
    lines: list[str] = []
    reader = threading.Thread(target=lambda: lines.extend(iter(proc.stderr.readline, "")), daemon=True)
    reader.start()
    stop = threading.Event()

    def publish() -> None:
        i = 0
        while not stop.wait(0.05):
            scan.publish(_msg("scan", i, time.time()))
            i += 1

    th = threading.Thread(target=publish, daemon=True)
    th.start()
    try:
        try:
            wait_until(lambda: any("scan=" in line and "map=" in line for line in lines) or proc.poll() is not None,
                       60, "a progress line counting scans and the map")
        except AssertionError as e:
            raise AssertionError(f"{e}; zenav record said: {lines[-3:]}") from None
        assert other.call("ping", m.Empty(), timeout=10) == m.Empty()
        assert proc.poll() is None, "".join(lines)
        proc.send_signal(signal.SIGTERM)
        proc.wait(60)
        reader.join(10)
    finally:
        stop.set()
        th.join()
        if proc.poll() is None:
            proc.kill()
    err = "".join(lines)
    assert proc.returncode == 0, err
    records = list(read_records(out))
    assert {r.topic for r in records} == {"scan", "map"}, {r.topic for r in records}
    maps = [r.msg for r in records if r.topic == "map"]
    assert len(maps) == 1  # latched: fetched once (the live publication came before the recorder)
    assert_ros1_equal(maps[0], grid)

    env = checkout_env(drop_zenav=True)
    for bad in (tmp_path / "no" / "dir.mcap", tmp_path):
        res = subprocess.run([sys.executable, "-m", "deploy.cli", "record", str(bad), "--robot", robot,
                              "--no-multicast"], env=env, capture_output=True, text=True, timeout=60)
        assert res.returncode == 2, res.stderr
        assert res.stderr.startswith("zenav record: cannot write") and res.stderr.count("\n") == 1, res.stderr


def test_messages_lost_while_the_recorder_was_frozen_are_counted_from_their_numbers(tmp_path, bus):
    """The recorder stopped (SIGSTOP) for longer than the link lease: this process closes the link and what
    odom published meanwhile never reaches it. Resumed, it dials again and records on. Its summary names the
    messages lost on the way (from the publisher's sequence numbers), and the file's messages plus the lost
    ones are exactly every message numbered from its first to its last."""
    robot, ep, hub, _ = bus
    pub = hub.publisher("odom")  # a stream: dropped, not queued, when the link is gone
    out, proc = _record(tmp_path, robot, ep, "--topics", "odom", "--progress", "0")
    stop, sent = threading.Event(), [0]

    def publish() -> None:
        while not stop.is_set():
            pub.publish(_msg("odom", sent[0], time.time()))
            sent[0] += 1
            stop.wait(0.02)

    th = threading.Thread(target=publish, daemon=True)
    try:
        wait_until(lambda: pub.matching, 60, "the recorder's subscription")
        th.start()
        wait_until(lambda: sent[0] >= 50, 30, "a second of odom")
        proc.send_signal(signal.SIGSTOP)
        wait_until(lambda: not pub.matching, 60, "the frozen recorder's link closed")
        frozen_at = sent[0]
        wait_until(lambda: sent[0] >= frozen_at + 50, 30, "odom sent while nobody listens")
        proc.send_signal(signal.SIGCONT)
        wait_until(lambda: pub.matching, 60, "the recorder back")
        back_at = sent[0]
        wait_until(lambda: sent[0] >= back_at + 50, 30, "a second of odom after it")
        stop.set()
        th.join()
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
    finally:
        stop.set()
        if proc.poll() is None:
            proc.send_signal(signal.SIGCONT)
            proc.kill()
    assert proc.returncode == 0, err
    seqs = [_seq("odom", r.msg) for r in read_records(out) if r.topic == "odom"]
    found = re.search(r"(\d+) message\(s\) lost on the way.*\(odom (\d+)\)", err)
    assert found, err
    lost = int(found[2])
    print(f"recorded {len(seqs)} odom, lost {lost}, numbered {seqs[0]}..{seqs[-1]}")
    assert lost >= 40, (lost, err)  # at least the 50 sent while the link was closed, less any sent before
    assert len(seqs) + lost == seqs[-1] - seqs[0] + 1, (len(seqs), lost, seqs[0], seqs[-1])
