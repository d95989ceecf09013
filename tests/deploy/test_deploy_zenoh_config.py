"""`zenav zenoh config` writes configs that real Zenoh sessions accept and that do what they say:
router + clients over loopback, usrpwd (wrong password -> no peers), cmd_vel access control on the
robot, mutual TLS identities. Sessions pin loopback endpoints on free ports, multicast off."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest
import zenoh
from deploy_helpers import env_for, free_port, start, stop, wait_line

from common.zenoh_config import BusConfig
from deploy.cli import build_parser


def gen(tmp_path, name: str, *argv: str) -> str:
    """Run `zenav zenoh config ARGV -o tmp/NAME.json5` (in-process, without exporting bus env)."""
    out = str(tmp_path / f"{name}.json5")
    args = build_parser(["deploy.cli.zenoh"]).parse_args(["zenoh", "config", *argv, "--no-multicast",
                                                           "-o", out])
    assert args.func(args) == 0
    return out


def wait_until(cond, timeout: float = 15.0, what: str = "condition"):
    end = time.monotonic() + timeout
    while not cond():
        if time.monotonic() > end:
            pytest.fail(f"timed out waiting for {what}")
        time.sleep(0.02)


def put_when_matched(session, key: str, value: str) -> None:
    """Put once the sender has seen the robot's subscriber (else the put goes nowhere)."""
    pub = session.declare_publisher(key)
    wait_until(lambda: pub.matching_status.matching, what=f"a subscriber for {key}")
    pub.put(value)
    pub.undeclare()


def collect(session, key: str) -> list[tuple[str, str]]:
    got: list[tuple[str, str]] = []
    session.declare_subscriber(key, lambda s: got.append((str(s.key_expr).split("/")[-1],
                                                           s.payload.to_string())))
    return got


@pytest.fixture
def sessions():
    opened: list[zenoh.Session] = []

    def open_(conf) -> zenoh.Session:  # a config file's path, or a zenoh.Config
        s = zenoh.open(zenoh.Config.from_file(conf) if isinstance(conf, str) else conf)
        opened.append(s)
        return s

    yield open_
    for s in reversed(opened):
        s.close()


@pytest.fixture
def creds(tmp_path):
    users = tmp_path / "users.txt"
    users.write_text("master:m-secret\nrobot:r-secret\n")
    for user, pw in (("master", "m-secret"), ("robot", "r-secret"), ("wrong", "not-the-password")):
        (tmp_path / f"{user}.pw").write_text(pw + "\n")
    return tmp_path


def test_generated_config_has_short_lease_and_parses(tmp_path):
    path = gen(tmp_path, "peer", "peer", "--listen", "tcp/127.0.0.1:7447")
    text = Path(path).read_text()
    assert text.startswith("//")
    conf = json.loads("\n".join(line for line in text.splitlines() if not line.startswith("//")))
    assert conf["transport"]["link"]["tx"]["lease"] == 1000
    assert conf["mode"] == "peer"
    assert json.loads(zenoh.Config.from_file(path).get_json("transport/link/tx/lease")) == 1000
    assert json.loads(zenoh.Config.from_file(path).get_json("transport/link/tx/queue/size/data")) == 16


def test_which_scouted_peer_dials_is_a_setting():
    """ZENAV_AUTOCONNECT: only the peer with the greater Zenoh id dials (zenav's default), or both (Zenoh's
    default; two peers dialling each other could leave a one-way session after a link loss, Zenoh #2806)."""
    import pytest

    from common.zenoh_config import BusConfig

    def to_peer(cfg: BusConfig) -> str:
        return json.loads(cfg.to_zenoh().get_json("scouting/multicast/autoconnect_strategy"))["peer"]["to_peer"]

    assert to_peer(BusConfig()) == "greater-zid"
    assert to_peer(BusConfig.from_env({})) == "greater-zid"
    assert to_peer(BusConfig.from_env({"ZENAV_AUTOCONNECT": "always"})) == "always"
    assert BusConfig.from_env({"ZENAV_AUTOCONNECT": "always"}).to_env()["ZENAV_AUTOCONNECT"] == "always"
    with pytest.raises(ValueError, match="greater-zid or always"):
        BusConfig(autoconnect="sometimes")


def test_gossip_is_on_unless_zenav_gossip_turns_it_off():
    """ZENAV_GOSSIP=0: only configured links and multicast scouting (a process group names every peer; a
    link found by gossip is not dialled again once it closes)."""
    from common.zenoh_config import BusConfig

    def enabled(cfg: BusConfig) -> bool:
        return json.loads(cfg.to_zenoh().get_json("scouting/gossip/enabled"))

    assert enabled(BusConfig.from_env({})) is True
    off = BusConfig.from_env({"ZENAV_GOSSIP": "0"})
    assert enabled(off) is False and off.to_env()["ZENAV_GOSSIP"] == "0"
    assert enabled(BusConfig.from_env(off.to_env())) is False  # handed on to an agent's children


def test_send_queue_holds_16_stream_messages_unless_a_config_file_says_otherwise(tmp_path):
    """Zenoh's 2-batch queue dropped best-effort messages whenever its send thread was a millisecond late
    on a busy CPU (common.zenoh_config.TX_QUEUE_BATCHES); a user's file keeps its own value."""
    from common.zenoh_config import BusConfig

    def queue(cfg: BusConfig) -> int:
        return json.loads(cfg.to_zenoh().get_json("transport/link/tx/queue/size/data"))

    assert queue(BusConfig()) == 16
    own = tmp_path / "own.json5"
    own.write_text('{transport: {link: {tx: {queue: {size: {data: 4}}}}}}')
    assert queue(BusConfig(zenoh_config_file=str(own))) == 4
    plain = tmp_path / "plain.json5"
    plain.write_text('{mode: "peer"}')
    assert queue(BusConfig(zenoh_config_file=str(plain))) == 16


def test_bad_options_are_refused_with_the_option_to_fix(tmp_path, capsys):
    ap = build_parser(["deploy.cli.zenoh"])
    args = ap.parse_args(["zenoh", "config", "client", "-o", str(tmp_path / "c.json5")])
    assert args.func(args) == 2
    assert "--connect" in capsys.readouterr().err
    args = ap.parse_args(["zenoh", "config", "peer", "--acl-cmd-vel-only", "master"])
    assert args.func(args) == 2
    assert "--users-file" in capsys.readouterr().err


def test_python_router_relays_between_clients_with_generated_configs(tmp_path, creds, sessions):
    port = free_port()
    ep = f"tcp/127.0.0.1:{port}"
    rconf = gen(tmp_path, "router", "router", "--listen", ep, "--users-file", str(creds / "users.txt"))
    router = start([sys.executable, "-m", "deploy.cli", "zenoh", "router", "--config", rconf], env_for())
    try:
        line = wait_line(router, "router ", timeout=30)
        assert ep in line
        master_c = gen(tmp_path, "mc", "client", "--connect", ep, "--user", "master",
                       "--password-file", str(creds / "master.pw"))
        robot_c = gen(tmp_path, "rc", "client", "--connect", ep, "--user", "robot",
                      "--password-file", str(creds / "robot.pw"))
        a, b = sessions(master_c), sessions(robot_c)
        assert a.info.routers_zid()
        assert b.info.routers_zid()
        got = collect(b, "zenav/r1/**")
        pub = a.declare_publisher("zenav/r1/cmd_vel")
        wait_until(lambda: pub.matching_status.matching, what="subscriber seen through the router")
        pub.put("go")
        wait_until(lambda: ("cmd_vel", "go") in got, what="message through the router")
        # A client with a wrong password cannot even open its session.
        bad = gen(tmp_path, "bad", "client", "--connect", ep, "--user", "master",
                  "--password-file", str(creds / "wrong.pw"))
        with pytest.raises(zenoh.ZError):
            zenoh.open(zenoh.Config.from_file(bad))
    finally:
        stop(router)


def test_peer_with_wrong_password_has_no_peers(tmp_path, creds, sessions):
    ep = f"tcp/127.0.0.1:{free_port()}"
    robot = sessions(gen(tmp_path, "robot", "peer", "--listen", ep, "--users-file", str(creds / "users.txt")))
    good = sessions(gen(tmp_path, "good", "peer", "--connect", ep, "--user", "master",
                        "--password-file", str(creds / "master.pw")))
    bad = sessions(gen(tmp_path, "bad", "peer", "--connect", ep, "--user", "master",
                       "--password-file", str(creds / "wrong.pw")))
    wait_until(lambda: good.info.peers_zid(), what="the good peer connected")
    wait_until(lambda: len(robot.info.peers_zid()) >= 1, what="robot sees the good peer")
    time.sleep(1.5)  # give the bad peer the same chance (connect retry period is 1 s)
    assert bad.info.peers_zid() == []
    assert [str(z) for z in robot.info.peers_zid()] == [str(good.zid())]


def assert_cmd_vel_only_from_master(tmp_path, creds, sessions, ep: str, robot, receiver) -> None:
    """Peers 'master' and 'other' connect to ``robot`` at ``ep`` and each put cmd_vel and scan: ``receiver``
    (the robot's session, or a node behind it) gets both scans and master's cmd_vel, never other's."""
    got = collect(receiver, "zenav/p3at/*")
    master = sessions(gen(tmp_path, "master", "peer", "--connect", ep, "--user", "master",
                          "--password-file", str(creds / "master.pw")))
    other = sessions(gen(tmp_path, "other", "peer", "--connect", ep, "--user", "robot",
                         "--password-file", str(creds / "robot.pw")))
    wait_until(lambda: len(robot.info.peers_zid()) == 2, what="both peers connected to the robot")
    for s, who in ((other, "other"), (master, "master")):
        put_when_matched(s, "zenav/p3at/cmd_vel", who)
        put_when_matched(s, "zenav/p3at/scan", who)
    wait_until(lambda: {("scan", "other"), ("scan", "master"), ("cmd_vel", "master")} <= set(got),
               what="master's cmd_vel and both scans")
    other.put("zenav/p3at/scan", "other-2")  # sent after its cmd_vel on the same link(s): a barrier
    wait_until(lambda: ("scan", "other-2") in got, what="the second scan")
    assert ("cmd_vel", "other") not in got


def test_robot_drops_cmd_vel_from_anyone_but_master_while_other_topics_pass(tmp_path, creds, sessions):
    ep = f"tcp/127.0.0.1:{free_port()}"
    robot = sessions(gen(tmp_path, "robot", "peer", "--listen", ep, "--user", "robot", "--password-file",
                         str(creds / "robot.pw"), "--users-file", str(creds / "users.txt"),
                         "--acl-cmd-vel-only", "master"))
    assert_cmd_vel_only_from_master(tmp_path, creds, sessions, ep, robot, robot)


@pytest.mark.skipif(shutil.which("openssl") is None, reason="needs openssl to make test certificates")
def test_mtls_identifies_master_whichever_side_connects(tmp_path, sessions):
    def ssl(*a):
        subprocess.run(["openssl", *a], cwd=tmp_path, check=True, capture_output=True, timeout=60)

    ssl("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-keyout", "ca.key", "-out", "ca.pem", "-days", "2",
        "-subj", "/CN=zenav-test-ca")
    for n in ("robot", "master", "other"):
        (tmp_path / f"{n}.ext").write_text("subjectAltName=DNS:localhost,IP:127.0.0.1\n")
        ssl("req", "-newkey", "rsa:2048", "-nodes", "-keyout", f"{n}.key", "-out", f"{n}.csr",
            "-subj", f"/CN={n}")
        ssl("x509", "-req", "-in", f"{n}.csr", "-CA", "ca.pem", "-CAkey", "ca.key", "-CAcreateserial",
            "-out", f"{n}.pem", "-days", "2", "-extfile", f"{n}.ext")

    def tls(n: str) -> list[str]:
        return ["--tls-ca", str(tmp_path / "ca.pem"), "--tls-cert", str(tmp_path / f"{n}.pem"),
                "--tls-key", str(tmp_path / f"{n}.key"), "--mtls"]

    # The robot opens the connections here (the case usrpwd cannot identify).
    m_ep, o_ep = f"tls/127.0.0.1:{free_port()}", f"tls/127.0.0.1:{free_port()}"
    master = sessions(gen(tmp_path, "master", "peer", "--listen", m_ep, *tls("master")))
    other = sessions(gen(tmp_path, "other", "peer", "--listen", o_ep, *tls("other")))
    robot = sessions(gen(tmp_path, "robot", "peer", "--connect", m_ep, "--connect", o_ep, *tls("robot"),
                         "--acl-cmd-vel-only", "master"))
    got = collect(robot, "zenav/p3at/*")
    wait_until(lambda: len(robot.info.peers_zid()) == 2, what="robot connected to both")
    for s, who in ((other, "other"), (master, "master")):
        put_when_matched(s, "zenav/p3at/cmd_vel", who)
    put_when_matched(other, "zenav/p3at/scan", "other")  # after its cmd_vel on the same link: a barrier
    wait_until(lambda: {("scan", "other"), ("cmd_vel", "master")} <= set(got), what="master's cmd_vel")
    assert ("cmd_vel", "other") not in got


def test_an_agents_nodes_get_cmd_vel_only_from_master_through_their_agent(tmp_path, creds, sessions):
    """Nodes of an agent (children: agent) are clients of its loopback port and leave access control to it:
    the agent's ingress filter must hold for what it forwards to them, and their own link must work
    with the robot's credentials."""
    ep = f"tcp/127.0.0.1:{free_port()}"
    robot_file = gen(tmp_path, "robot", "peer", "--listen", ep, "--user", "robot", "--password-file",
                     str(creds / "robot.pw"), "--users-file", str(creds / "users.txt"),
                     "--acl-cmd-vel-only", "master")
    local = f"tcp/127.0.0.1:{free_port()}"
    agent = sessions(BusConfig(zenoh_config_file=robot_file, local_listen=(local,)).to_zenoh())
    node = sessions(BusConfig(zenoh_config_file=robot_file, via_agent=local).to_zenoh())
    assert_cmd_vel_only_from_master(tmp_path, creds, sessions, ep, agent, node)
