"""`zenav goal` refuses non-finite numbers and says at once which move_base it waits for."""

from __future__ import annotations

import subprocess
import sys
import time

import pytest
from bushelp import REPO, child_env, free_port

ZENAV = [sys.executable, "-m", "deploy.cli"]


@pytest.mark.parametrize("args", [["nan", "0", "0"], ["0", "inf", "0"], ["--", "0", "0", "-inf"], ["1", "x", "0"],
                                  ["1", "2", "0", "--wait", "0"], ["1", "2", "0", "--timeout", "nan"]])
def test_goal_refuses_non_finite_and_non_numeric_input(args):
    r = subprocess.run([*ZENAV, "goal", *args], env=child_env("nobody"), capture_output=True, text=True,
                       timeout=60, cwd=REPO)
    assert r.returncode == 2, r.stdout + r.stderr
    assert "Traceback" not in r.stderr
    assert "finite number" in r.stderr or "not a number" in r.stderr or "must be > 0" in r.stderr, r.stderr


def test_goal_without_move_base_names_the_robot_at_once_and_gives_up_after_wait(robot_name):
    # no peer anywhere: multicast off, nothing to connect to
    env = child_env(robot_name, multicast=False)
    t0 = time.monotonic()
    p = subprocess.Popen([*ZENAV, "goal", "1", "2", "0", "--wait", "1.5"], env=env, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, cwd=REPO)
    try:
        first = p.stdout.readline()
        assert f"to move_base of robot '{robot_name}'" in first, first
        out, err = p.communicate(timeout=60)
    finally:
        if p.poll() is None:
            p.kill()
    assert p.returncode == 2
    assert "Traceback" not in err
    lines = out.splitlines()
    assert len(lines) == 1, out  # one line saying why
    assert f"move_base of robot '{robot_name}' did not answer within 2 s" in lines[0], out
    assert "no node serving it was reachable; its status never seen" in lines[0], out
    assert time.monotonic() - t0 < 45  # the default used to be a silent minute


def test_goal_to_a_move_base_that_never_answers_exits_2_in_time_with_one_line(node_pair, robot_name):
    """A move_base that is there (its status flows, its goal service is declared) but never answers: a hung
    node, or a link that carries one direction only. `zenav goal` must not wait past --wait."""
    import threading

    from common.messages import Header, MoveBaseStatus

    hung = node_pair("move_base")
    release = threading.Event()
    hung.service("move_base/send_goal", lambda _req: release.wait(60))
    status = hung.publisher("move_base/status")
    hung.timer(0.1, lambda: status.publish(MoveBaseStatus(Header(hung.clock.now(), "map"), state="IDLE")))
    env = child_env(robot_name, multicast=False, connect=hung.config.listen)
    t0 = time.monotonic()
    try:
        r = subprocess.run([*ZENAV, "goal", "1", "2", "0", "--wait", "4"], env=env, capture_output=True,
                           text=True, timeout=60, cwd=REPO)
    finally:
        release.set()
    took = time.monotonic() - t0
    assert r.returncode == 2, r.stdout + r.stderr
    assert "Traceback" not in r.stderr
    last = r.stdout.strip().splitlines()[-1]
    assert f"move_base of robot '{robot_name}' did not answer within 4 s" in last, r.stdout
    assert "it was reachable but did not answer; its status last seen" in last, r.stdout
    assert took < 4 + 20, took  # the deadline, plus the start of a Python process on a loaded machine


def test_tools_use_the_only_robot_on_the_network_and_say_so(node_pair, robot_name):
    from procs import make_scan

    node = node_pair("lidar")
    scan = node.publisher("scan")
    node.timer(0.05, lambda: scan.publish(make_scan(1, 90, node.clock.now())))
    env = child_env(robot_name, multicast=False, connect=node.config.listen)
    env.pop("ZENAV_ROBOT")
    r = subprocess.run([*ZENAV, "topic", "echo", "scan", "-n", "1"], env=env, capture_output=True, text=True,
                       timeout=120, cwd=REPO)
    assert r.returncode == 0, r.stderr
    assert f"using robot '{robot_name}', the only one on the network" in r.stderr
    assert r.stdout.startswith("LaserScan ")
    # a second robot: the tool no longer guesses, it lists them. Its node listens too and the tool connects
    # to both (with only the hub to connect to, the second robot's token reached a new peer only once
    # gossip had connected the two: seen late under load)
    from common.bus import Node
    from common.zenoh_config import BusConfig

    port_b = free_port()
    other = Node("lidar", config=BusConfig(robot=robot_name + "b", multicast=False, connect=node.config.listen,
                                           listen=(f"tcp/127.0.0.1:{port_b}",)))
    try:
        env = child_env(robot_name, multicast=False, connect=(*node.config.listen, f"tcp/127.0.0.1:{port_b}"))
        env.pop("ZENAV_ROBOT")
        r = subprocess.run([*ZENAV, "topic", "echo", "scan", "-n", "1"], env=env, capture_output=True, text=True,
                           timeout=60, cwd=REPO)
    finally:
        other.close()
    assert r.returncode == 2, r.stdout + r.stderr
    assert f"several robots on the network ({robot_name}, {robot_name}b)" in r.stderr, r.stderr
    assert "Traceback" not in r.stderr
