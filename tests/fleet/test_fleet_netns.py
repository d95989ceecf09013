"""``zenav fleet`` against real hosts: network namespaces on a bridge, each with its own sshd.

robot1 runs the simulated P3-AT (robot_side/config/p3at_sim.yaml), master1 the master on the known
map (master_side/config/p3at_known_map.yaml); shared memory off (the namespaces share /dev/shm). The
inventory has ``security: {cmd_vel_acl: true}``: everything runs with the generated Zenoh usrpwd
authentication and cmd_vel access control (multicast off, the master connects to the robot). The tests
of this module run in order on one set of hosts: install + up + status + a goal, another robot's master
refused by robot1, status finding three planted problems, a rolling upgrade, down. Clock offset: a
namespace cannot have its own clock, so robot1's ``clock_cmd`` adds 0.2 s.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml
from fleet_hosts import SSH_OPTS, FleetHosts, python_for_hosts, requirements

from deploy.fleet import inventory, render

REPO = Path(__file__).resolve().parents[2]
pytestmark = [pytest.mark.netns, pytest.mark.slow]
GOAL = ("-1.2", "0.3", "0.0")  # 1 m ahead of the room world's start (-2.2, 0, 0)
SKEWED_CLOCK = "awk -v t=\"$(date +%s.%N)\" 'BEGIN { printf \"%.6f\\n\", t + 0.2 }'"
T0 = time.monotonic()


def _inventory(hosts: FleetHosts, robot: str, tmp: Path, clock_cmd: str = "") -> dict:
    def host(name: str, role: str, config: str) -> dict:
        d = {"address": hosts.address(name), "role": role, "robot": robot, "config": config,
             "install_dir": str(tmp / "hosts" / name / "zenav"), "sysroot": str(tmp / "hosts" / name / "root")}
        return d

    inv = {
        "security": {"cmd_vel_acl": True, "secrets_dir": str(tmp / "secrets")},
        "defaults": {"ssh": {"user": "root", "key": str(hosts.key), "options": SSH_OPTS},
                     "python": python_for_hosts(), "zenoh": {"mode": "peer", "shared_memory": False},
                     # the namespaces have no route to PyPI (local wheels); setuptools + wheel come from the
                     # venv's system site-packages instead of an isolated build env (~60 s of CPU saved)
                     "pip_args": ["--retries", "0", "--no-build-isolation"]},
        "hosts": {"robot1": host("robot1", "robot", "robot_side/config/p3at_sim.yaml"),
                  "master1": host("master1", "master", "master_side/config/p3at_known_map.yaml")},
    }
    # master1 without pip (install_mode: link): pip's build costs CPU this shared 2-core machine lacks
    inv["hosts"]["master1"]["install_mode"] = "link"
    if clock_cmd:
        inv["hosts"]["robot1"]["clock_cmd"] = clock_cmd
    return inv


@pytest.fixture(scope="module")
def fleet(tmp_path_factory):
    requirements()
    tmp = tmp_path_factory.mktemp("fleet")
    hosts = FleetHosts(tmp, ["robot1", "master1"])
    robot = "f" + hosts.sfx + "x"
    try:
        hosts.up()
        inv = tmp / "fleet.yaml"
        inv.write_text(yaml.safe_dump(_inventory(hosts, robot, tmp)))
        skewed = tmp / "fleet_skewed.yaml"
        skewed.write_text(yaml.safe_dump(_inventory(hosts, robot, tmp, SKEWED_CLOCK)))
        yield {"hosts": hosts, "inv": inv, "skewed": skewed, "robot": robot, "tmp": tmp}
    finally:
        hosts.down()


def zenav(*args: str, timeout: float = 240) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENAV_")}
    t0 = time.monotonic()
    r = subprocess.run([sys.executable, "-m", "deploy.cli", *args], cwd=REPO, env=env, capture_output=True,
                       text=True, timeout=timeout)
    print(f"$ zenav {' '.join(args)}  ({time.monotonic() - t0:.1f} s, exit {r.returncode})\n{r.stdout}{r.stderr}")
    return r


def status_until(inv: Path, ok: bool, timeout: float = 60) -> subprocess.CompletedProcess:
    deadline = time.monotonic() + timeout
    while True:
        r = zenav("fleet", "-i", str(inv), "status", "--seconds", "1.5")
        if (r.returncode == 0) == ok or time.monotonic() > deadline:
            return r
        time.sleep(1)


def test_fleet_install_up_status_and_a_goal(fleet):
    inv, hosts = str(fleet["inv"]), fleet["hosts"]
    r = zenav("fleet", "-i", inv, "check")
    assert r.returncode == 0 and r.stdout.count("] ok: ") == 2, r.stdout + r.stderr
    r = zenav("fleet", "-i", inv, "install", "--dry-run")
    assert r.returncode == 0, r.stderr
    assert "python3 -m venv" not in r.stdout and "-m venv --system-site-packages" in r.stdout
    assert "write " + str(fleet["tmp"] / "hosts/robot1/root/etc/udev/rules.d/99-pioneer.rules") in r.stdout
    assert not (fleet["tmp"] / "hosts").exists(), "--dry-run changed something"

    r = zenav("fleet", "-i", inv, "install")
    assert r.returncode == 0, r.stdout + r.stderr
    assert "supervisor" in r.stdout  # no systemd here: detected
    src = fleet["tmp"] / "hosts/robot1/zenav/src"
    assert (src / "deploy/fleet/supervise.py").is_file()
    assert "ZENAV_SHM=0" in (fleet["tmp"] / "hosts/robot1/zenav/etc/zenav.env").read_text()
    r = zenav("fleet", "-i", inv, "install", "robot1")  # idempotent: again, nothing reinstalled
    assert r.returncode == 0 and "zenav already installed" in r.stdout, r.stdout + r.stderr

    r = zenav("fleet", "-i", inv, "up")
    assert r.returncode == 0, r.stdout + r.stderr
    r = status_until(fleet["inv"], ok=True, timeout=90)
    assert r.returncode == 0, r.stdout
    assert "robot1" in r.stdout and "active" in r.stdout and "all fine" in r.stdout

    # a goal, from a process on the master host with the master's identity (its generated zenav.env)
    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENAV_")}
    env.update(host_env(fleet["tmp"] / "hosts/master1/zenav/etc/zenav.env"), PYTHONPATH=str(REPO))
    g = subprocess.run(["ip", "netns", "exec", hosts.ns["master1"], sys.executable, "-m", "deploy.cli", "goal",
                        *GOAL, "--timeout", "90", "--wait", "60", "--quiet"], cwd=REPO, env=env,
                       capture_output=True, text=True, timeout=180)
    print("goal:", g.stdout, g.stderr)
    assert g.returncode == 0, g.stdout + g.stderr
    r = zenav("fleet", "-i", inv, "logs", "robot1", "sim", "-n", "5")
    assert r.returncode == 0 and "[sim]" in r.stdout, r.stdout


def host_env(path: Path) -> dict[str, str]:
    return dict(line.split("=", 1) for line in path.read_text().splitlines() if "=" in line and line[0] != "#")


def _publisher(fleet, env_file: Path, text: str, seconds: float) -> list[str]:
    """A cmd_vel publisher in master1's namespace with the Zenoh identity of ``env_file``, connecting to
    robot1: its output (``PEERS n`` once the robot let it in)."""
    hosts = fleet["hosts"]
    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENAV_")}
    env.update(ZENAV_CONNECT=f"tcp/{hosts.address('robot1')}:7447", ACL_PROC_EXIT_ON_PEERS="1")
    cmd = ["ip", "netns", "exec", hosts.ns["master1"], "timeout", str(seconds), sys.executable,
           str(Path(__file__).parent / "acl_proc.py"), str(env_file), "pub", f"zenav/{fleet['robot']}/cmd_vel", text]
    r = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=seconds + 30)
    return r.stdout.split("\n")


def test_fleet_robot_refuses_another_robots_master(fleet):
    """robot1 lets in its own master's identity and refuses master2's (another robot's master, same
    generated security): its cmd_vel never reaches robot1 (tests/fleet/test_fleet_acl.py: an
    authenticated non-master's cmd_vel is dropped by the access control)."""
    data = yaml.safe_load(fleet["inv"].read_text())
    tmp = fleet["tmp"]
    data["hosts"]["robot2"] = {**data["hosts"]["robot1"], "address": "10.255.0.2", "robot": "other",
                               "install_dir": str(tmp / "hosts/robot2/zenav")}
    data["hosts"]["master2"] = {**data["hosts"]["master1"], "robot": "other",
                                "install_dir": str(tmp / "hosts/master2/zenav")}
    (tmp / "fleet2.yaml").write_text(yaml.safe_dump(data))
    inv = inventory.load(tmp / "fleet2.yaml")
    m2 = inv.host("master2")
    p = render.paths(m2)
    for path, text in ((p["env"], render.env_file(inv, m2)), (p["zenoh"], render.zenoh_json(inv, m2)),
                       (p["users"], render.users_txt(inv, m2))):
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        Path(path).write_text(text)
    own = _publisher(fleet, tmp / "hosts/master1/zenav/etc/zenav.env", "own", 20)
    assert any(x.startswith("PEERS") for x in own), f"master1's identity was not let in: {own}"
    wrong = _publisher(fleet, Path(p["env"]), "wrong", 6)  # longer than the own master needed
    assert not any(x.startswith("PEERS") for x in wrong), f"robot1 let master2 in: {wrong}"


def _node_pid(hosts: FleetHosts, host: str, node: str) -> int:
    for pid in hosts.pids(host):
        try:
            argv = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
        except OSError:
            continue
        if b"--name" in argv and argv[argv.index(b"--name") + 1] == node.encode():
            return pid
    raise AssertionError(f"no process of node {node} on {host}")


def test_fleet_status_finds_stopped_service_missing_node_and_clock_offset(fleet):
    inv, hosts = str(fleet["inv"]), fleet["hosts"]
    assert zenav("fleet", "-i", inv, "down", "master1").returncode == 0
    os.kill(_node_pid(hosts, "robot1", "Pioneer3AT_laserscan_tf"), 15)  # no respawn: stays missing
    time.sleep(1.0)
    r = zenav("fleet", "-i", str(fleet["skewed"]), "status", "--seconds", "1.5")
    out = r.stdout
    assert r.returncode == 1, out
    assert "master1: FAIL  service: zenav-master inactive" in out, out
    assert "fix: zenav fleet up master1" in out
    assert "robot1: FAIL  nodes: missing Pioneer3AT_laserscan_tf" in out, out
    assert "zenav fleet restart robot1" in out
    assert "chrony" in out
    clock = next(line for line in out.splitlines() if "robot1: WARN  clock:" in line)
    assert 150 <= int(clock.split("clock: +")[1].split(" ms")[0]) <= 250, clock

    # the fixes it names: (the upgrade below then waits until every node of both hosts is back)
    assert zenav("fleet", "-i", inv, "restart", "robot1").returncode == 0
    assert zenav("fleet", "-i", inv, "up", "master1").returncode == 0


def test_fleet_rolling_upgrade(fleet):
    inv = str(fleet["inv"])
    before = {h: (fleet["tmp"] / f"hosts/{h}/zenav/run/zenav-{h[:-1]}.pid").read_text() for h in ("robot1", "master1")}
    r = zenav("fleet", "-i", inv, "upgrade", "--timeout", "90", timeout=400)
    assert r.returncode == 0, r.stdout + r.stderr
    lines = [line for line in r.stdout.splitlines() if "upgraded: nodes back" in line]
    assert [line.split("]")[0] for line in lines] == ["[robot1", "[master1"], r.stdout  # one at a time, in order
    back = float(lines[0].split("nodes back ")[1].split(" s")[0])
    assert back < 60, lines[0]
    after = {h: (fleet["tmp"] / f"hosts/{h}/zenav/run/zenav-{h[:-1]}.pid").read_text() for h in before}
    assert all(after[h] != before[h] for h in before), "services were not restarted"


def test_fleet_down_stops_everything(fleet):
    hosts = fleet["hosts"]
    r = zenav("fleet", "-i", str(fleet["inv"]), "down")
    assert r.returncode == 0, r.stdout + r.stderr
    def cmdline(pid: int) -> bytes:
        try:
            return Path(f"/proc/{pid}/cmdline").read_bytes()
        except OSError:
            return b"sshd (gone)"

    for h in ("robot1", "master1"):
        left = [cmdline(p) for p in hosts.pids(h) if b"sshd" not in cmdline(p)]
        assert not left, f"processes left on {h}: {left}"
    r = zenav("fleet", "-i", str(fleet["inv"]), "status", "--seconds", "1")
    assert r.returncode == 1 and "inactive" in r.stdout
    print(f"fleet module: {time.monotonic() - T0:.0f} s")
