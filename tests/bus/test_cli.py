"""`zenav` CLI smoke tests against a publisher in this test process (CLI runs as a subprocess)."""

from __future__ import annotations

import re
import signal
import subprocess
import sys
import threading

import numpy as np
import pytest
from bushelp import REPO, child_env
from procs import make_scan

from common.codec import encode
from common.messages import Header, OccupancyGrid

ZENAV = [sys.executable, "-m", "deploy.cli"]


@pytest.fixture
def live_robot(node_pair, robot_name):
    """A node publishing 720-beam scans at 20 Hz and a latched map; CLI env connecting to it."""
    node = node_pair("lidar")
    scan = node.publisher("scan")
    seq = [0]

    def tick() -> None:
        seq[0] += 1
        scan.publish(make_scan(seq[0], 720, node.clock.now()))

    node.timer(0.05, tick)
    node.publisher("map", latched=True).publish(
        OccupancyGrid(Header(1.0, "map"), 0.05, data=-np.ones((20, 30), np.int8))
    )
    env = child_env(robot_name, multicast=False, connect=node.config.listen)
    return env


def _run(args: list[str], env: dict, timeout: float = 60.0) -> subprocess.CompletedProcess:
    r = subprocess.run([*ZENAV, *args], env=env, capture_output=True, text=True, timeout=timeout, cwd=REPO)
    assert r.returncode == 0, r.stderr
    assert "Traceback" not in r.stderr, r.stderr
    return r


def test_help_explains_discovery_and_lists_subcommands():
    r = _run(["--help"], env=child_env("x"))
    assert "multicast" in r.stdout.lower()
    assert "no master" in r.stdout.lower()
    for cmd in ("topic", "nodes"):
        assert re.search(rf"^\s+{cmd}\s", r.stdout, re.M), r.stdout
    r = _run(["topic", "hz", "--help"], env=child_env("x"))
    assert "--window" in r.stdout
    assert "--robot" in r.stdout


def test_topic_list_shows_type_rate_and_publisher(live_robot, robot_name):
    out = _run(["topic", "list", "--wait", "1.5"], live_robot).stdout
    rows = {line.split()[1]: line.split() for line in out.splitlines()[1:]}
    assert rows["scan"][0] == robot_name
    assert rows["scan"][2] == "LaserScan"
    assert rows["scan"][4] == "lidar"
    assert 5.0 < float(rows["scan"][3]) < 40.0  # ~20 Hz, loose on a loaded machine
    assert rows["map"][2] == "OccupancyGrid"  # latched and silent: type asked from its publisher
    # all robots
    out = _run(["--robot", "*", "topic", "list", "--wait", "1.0"], live_robot).stdout
    assert any(line.split()[:3] == [robot_name, "scan", "LaserScan"] for line in out.splitlines())


def test_topic_echo_prints_compact_one_line_summaries(live_robot):
    out = _run(["topic", "echo", "scan", "-n", "3"], live_robot).stdout.splitlines()
    assert len(out) == 3
    for line in out:
        assert line.startswith("LaserScan ")
        assert "ranges=float32[720]" in line
        assert "(1 non-finite)" in line
        assert len(line) < 400
    latched = _run(["topic", "echo", "map", "-n", "1"], live_robot).stdout
    assert "OccupancyGrid" in latched
    assert "data=int8[20, 30] -1..-1" in latched


def test_topic_hz_reports_the_publishing_rate(live_robot):
    out = _run(["topic", "hz", "scan", "--window", "50", "--duration", "4"], live_robot).stdout
    rates = [float(m) for m in re.findall(r"average rate: ([\d.]+)", out)]
    assert rates, out
    assert 10.0 < rates[-1] < 30.0, out  # published at 20 Hz
    assert re.search(r"min: [\d.]+s max: [\d.]+s std dev: [\d.]+s window: \d+", out)


def test_nodes_lists_live_nodes(live_robot, robot_name):
    out = _run(["nodes", "-l"], live_robot).stdout
    assert re.search(rf"^{robot_name}\s+lidar\s+.*pub:scan", out, re.M), out
    assert "pub:map" in out


@pytest.mark.parametrize("cmd", [["topic", "echo", "scan"], ["topic", "hz", "scan"], ["nodes", "--watch"]])
def test_streaming_commands_exit_cleanly_on_ctrl_c(live_robot, cmd):
    p = subprocess.Popen(
        [*ZENAV, *cmd], env=live_robot, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=REPO
    )
    first = threading.Event()
    threading.Thread(target=lambda: (p.stdout.readline(), first.set()), daemon=True).start()
    try:
        assert first.wait(60), "no output"
        p.send_signal(signal.SIGINT)
        assert p.wait(30) == 0
        assert "Traceback" not in p.stderr.read()
    finally:
        if p.poll() is None:
            p.kill()


def test_nodes_stats_shows_each_subscriptions_counters(live_robot, node_pair, robot_name):
    from bushelp import wait_for

    from common.messages import LaserScan
    listener = node_pair("listener")
    sub = listener.subscribe("scan", LaserScan)
    wait_for(lambda: sub.received >= 3, 30, "scans at the listener")
    raw = node_pair("rogue").session.declare_publisher(f"zenav/{robot_name}/scan")
    wait_for(lambda: raw.matching_status.matching, 30, "the listener's subscription seen by the rogue")
    for _ in range(3):
        raw.put(b"not msgpack at all")
    bad = make_scan(1, 720, 1.0)
    raw.put(encode(LaserScan(bad.header, bad.angle_min, bad.angle_max, 0.0, 0.0, 0.0, 0.1, 10.0, bad.ranges)))
    wait_for(lambda: sub.malformed == 3 and sub.invalid == 1, 30, "the rogue payloads counted")
    out = _run(["nodes", "--stats"], live_robot).stdout
    line = re.search(rf"^{robot_name}\s+listener\s+scan\s+LaserScan\s+(\d+)\s+(\d+)\s+(\d+)\s+(\d+)\s+(\d+)$",
                     out, re.M)
    assert line, out
    received, malformed, invalid, _, errors = map(int, line.groups())
    assert received >= 3 and (malformed, invalid, errors) == (3, 1, 0), out
