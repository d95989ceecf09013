"""`zenav doctor` against a private loopback bus (fake robot publishing scan/odom/tf: all PASS, exit 0;
nothing running: FAILs with fixes, exit 1), its pure checks, and across two network namespaces with
the default config (peer + multicast)."""

from __future__ import annotations

import os
import sys

import pytest
from deploy_helpers import HELPER, env_for, free_port, start, stop, wait_line, zenav

from deploy.doctor.host_checks import serial_check, skew_check
from tests.support import two_netns


@pytest.fixture
def fake_robot(robot_name):
    procs = []

    def run(env, prefix=()):
        p = start([*prefix, sys.executable, HELPER, "fakerobot"], env)
        procs.append(p)
        wait_line(p, "READY", timeout=60)
        return p

    yield run
    for p in procs:
        stop(p)


def _lines(out: str, status: str) -> list[str]:
    return [line for line in out.splitlines() if line.startswith(status)]


def test_doctor_passes_when_robot_topics_flow_on_loopback(fake_robot, robot_name):
    ep = f"tcp/127.0.0.1:{free_port()}"
    fake_robot(env_for(robot_name, ZENAV_MULTICAST="0", ZENAV_LISTEN=ep))
    r = zenav(["doctor", "--robot", robot_name, "--no-multicast", "--connect", ep, "--timeout", "2"],
              env_for())
    assert r.returncode == 0, r.stdout + r.stderr
    out = r.stdout
    assert "mode peer" in out
    assert "multicast off" in out
    assert "lease 1000 ms" in out
    assert f"[{robot_name}] nodes alive: 1: fake_base" in out
    for t in ("scan", "odom", "tf"):
        assert any(f"topic {t}:" in line and "Hz" in line for line in _lines(out, "PASS")), out
    assert any("TF odom→base_link fresh" in line for line in _lines(out, "PASS")), out
    assert any("clock skew" in line for line in _lines(out, "PASS")), out
    assert any("routes to its nodes: 1 of 1 answer a query" in line for line in _lines(out, "PASS")), out
    assert not _lines(out, "FAIL")
    assert not _lines(out, "WARN")


def test_doctor_names_a_node_whose_token_arrives_but_whose_queries_do_not(fake_robot, robot_name):
    """A node seen alive that answers no query (a hung node, or a route that formed one way only)."""
    import zenoh

    from common.zenoh_config import BusConfig

    ep = f"tcp/127.0.0.1:{free_port()}"
    fake_robot(env_for(robot_name, ZENAV_MULTICAST="0", ZENAV_LISTEN=ep))
    ghost_ep = f"tcp/127.0.0.1:{free_port()}"
    ghost = zenoh.open(BusConfig(robot=robot_name, multicast=False, connect=(ep,), listen=(ghost_ep,)).to_zenoh())
    try:
        token = ghost.liveliness().declare_token(f"zenavlive/{robot_name}/node/ghost")  # and no node_stats
        r = zenav(["doctor", "--robot", robot_name, "--no-multicast", "--connect", f"{ep},{ghost_ep}",
                   "--timeout", "2"], env_for())
        token.undeclare()
    finally:
        ghost.close()
    assert r.returncode == 1, r.stdout + r.stderr
    fails = _lines(r.stdout, "FAIL")
    assert any("routes to its nodes" in line and "ghost alive (token seen) but no answer" in line
               for line in fails), r.stdout
    assert "fake_base" not in " ".join(line for line in fails if "routes" in line), r.stdout


def test_doctor_fails_with_fixes_when_nothing_runs(robot_name, tmp_path):
    ep = f"tcp/127.0.0.1:{free_port()}"  # nobody listens there
    r = zenav(["doctor", "--robot", robot_name, "--no-multicast", "--connect", ep, "--timeout", "1",
               "--serial", str(tmp_path / "pioneer")], env_for())
    assert r.returncode == 1, r.stdout + r.stderr
    fails = _lines(r.stdout, "FAIL")
    names = " | ".join(fails)
    for what in ("configured endpoints reached", "zenav nodes alive", "topic scan", "topic odom", "topic tf",
                 "serial port"):
        assert what in names, r.stdout
    assert r.stdout.count("fix: ") >= len(fails)
    assert "--listen tcp/0.0.0.0:7447" in r.stdout  # the endpoint fix names the option


def test_skew_check_estimates_offset_from_smallest_delay():
    latency = [0.001, 0.004, 0.02]
    assert skew_check([0.2 + d for d in latency], 0.05, False).status == "WARN"
    c = skew_check([-0.3 + d for d in latency], 0.05, False)
    assert c.status == "WARN"
    assert "299 ms ahead" in c.detail
    assert "chrony" in c.fix
    assert skew_check([0.01 + d for d in latency], 0.05, False).status == "PASS"
    assert skew_check([5.0], 0.05, True).status == "SKIP"  # simulated time: not comparable


def test_serial_check_accepts_a_tty_and_refuses_files_and_missing_paths(tmp_path):
    master, slave = os.openpty()
    try:
        assert serial_check(os.ttyname(slave)).status == "PASS"
    finally:
        os.close(master)
        os.close(slave)
    plain = tmp_path / "not_a_tty"
    plain.write_text("")
    assert serial_check(str(plain)).status == "FAIL"
    missing = serial_check(str(tmp_path / "pioneer"))
    assert missing.status == "FAIL"
    assert "udev" in missing.fix


# -- two hosts ------------------------------------------------------------------------------------------
@pytest.fixture
def two_hosts():
    with two_netns("d", "10.78.0") as hosts:
        yield hosts["a"], hosts["b"]


@pytest.mark.netns
def test_doctor_in_one_namespace_sees_the_robot_in_the_other_with_default_config(two_hosts, fake_robot,
                                                                                robot_name):
    a, b = two_hosts
    fake_robot(env_for(robot_name, ZENAV_SHM="0"), prefix=["ip", "netns", "exec", a])
    r = zenav(["doctor", "--robot", robot_name, "--timeout", "4"], env_for(ZENAV_SHM="0"),
              prefix=["ip", "netns", "exec", b])
    out = r.stdout
    assert r.returncode == 0, out + r.stderr
    assert "multicast on" in out
    assert "connect none" in out
    assert any("multicast scouting" in line for line in _lines(out, "PASS")), out
    assert f"[{robot_name}] nodes alive: 1: fake_base" in out
