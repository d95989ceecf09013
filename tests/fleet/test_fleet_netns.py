"""``zenav fleet`` against real hosts: network namespaces on a bridge, each with its own sshd.

robot1 runs the simulated P3-AT (robot_side/config/p3at_sim.yaml), master1 the master on the known
map (master_side/config/p3at_known_map.yaml); shared memory off (the namespaces share /dev/shm). The
fleet is secured (``security: {cmd_vel_acl: true}``): every host runs its own Zenoh router (usrpwd; the
robot's holds the cmd_vel access control), its processes are the router's clients and each master's
router opens the link to its robot's (deploy/fleet/secured.py). The tests of this module run in order on
one set of hosts: install + up + status + a goal; a second robot with its own master (robot2 + master2,
another inventory holding all four hosts), a goal to each robot at once, then cmd_vel towards robot1
from master2's identity and from robot1's own (not a master) — robot1 does not move —, while master1's
arrives; status finding three planted problems; a rolling upgrade; down. Clock offset: a namespace
cannot have its own clock, so robot1's ``clock_cmd`` adds 0.2 s.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import time
from pathlib import Path

import pytest
import yaml
from fleet_hosts import (
    FleetHosts,
    inventory,
    kill_group,
    node_pid,
    on_host,
    output,
    requirements,
    seed_kernels,
    status_until,
    zenav,
)

from tests.support import wait_until

pytestmark = [pytest.mark.netns, pytest.mark.slow]
GOAL = ("-1.2", "0.3", "0.0")  # 1 m ahead of the room world's start (-2.2, 0, 0)
GOAL_B = ("-0.6", "1.0", "0.0")  # robot1's second goal: from GOAL, 1 m on, clear of the crate at (0, 0)
SKEWED_CLOCK = "awk -v t=\"$(date +%s.%N)\" 'BEGIN { printf \"%.6f\\n\", t + 0.2 }'"
T0 = time.monotonic()
HERE = Path(__file__).resolve().parent


@pytest.fixture(scope="module")
def fleet(tmp_path_factory):
    requirements()
    tmp = tmp_path_factory.mktemp("fleet")
    hosts = FleetHosts(tmp, ["robot1", "master1", "robot2", "master2"])
    robot, robot2 = "f" + hosts.sfx + "x", "f" + hosts.sfx + "y"
    try:
        hosts.up()
        for name, robots in (("fleet", {"1": robot}), ("fleet2", {"1": robot, "2": robot2})):
            (tmp / f"{name}.yaml").write_text(yaml.safe_dump(inventory(hosts, robots, tmp, acl=True)))
        skewed = tmp / "fleet_skewed.yaml"
        skewed.write_text(yaml.safe_dump(inventory(hosts, {"1": robot}, tmp, SKEWED_CLOCK, acl=True)))
        yield {"hosts": hosts, "inv": tmp / "fleet.yaml", "inv2": tmp / "fleet2.yaml", "skewed": skewed,
               "robot": robot, "robot2": robot2, "tmp": tmp}
    finally:
        hosts.down()


def test_fleet_install_up_status_and_a_goal(fleet):
    inv = str(fleet["inv"])
    r = zenav("fleet", "-i", inv, "check")
    assert r.returncode == 0 and r.stdout.count("] ok: ") == 2, r.stdout + r.stderr
    r = zenav("fleet", "-i", inv, "install", "--dry-run")
    assert r.returncode == 0, r.stderr
    assert "python3 -m venv" not in r.stdout and "-m venv --system-site-packages" in r.stdout
    assert "write " + str(fleet["tmp"] / "hosts/robot1/root/etc/udev/rules.d/99-pioneer.rules") in r.stdout
    assert not (fleet["tmp"] / "hosts").exists(), "--dry-run changed something"

    seed_kernels(fleet["tmp"] / "hosts/master1/zenav")  # after the dry run: it must find nothing there
    r = zenav("fleet", "-i", inv, "install", timeout=900)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "supervisor" in r.stdout  # no systemd here: detected
    src = fleet["tmp"] / "hosts/robot1/zenav/src"
    assert (src / "deploy/fleet/supervise.py").is_file()
    env = (fleet["tmp"] / "hosts/robot1/zenav/etc/zenav.env").read_text()
    assert "ZENAV_SHM=0" in env and "ZENAV_MODE=client" in env  # secured: a client of the host's router
    assert (fleet["tmp"] / "hosts/robot1/zenav/etc/router.json5").is_file()
    r = zenav("fleet", "-i", inv, "install", "robot1", timeout=600)  # idempotent: again, nothing reinstalled
    assert r.returncode == 0 and "zenav already installed" in r.stdout, r.stdout + r.stderr

    r = zenav("fleet", "-i", inv, "up")
    assert r.returncode == 0, r.stdout + r.stderr
    r = status_until(fleet["inv"], ok=True, timeout=180)
    assert r.returncode == 0, r.stdout
    assert "robot1" in r.stdout and "active" in r.stdout and "all fine" in r.stdout

    g = _goal(fleet, "master1", GOAL)
    out = output(g, 320)
    assert g.returncode == 0, out
    r = zenav("fleet", "-i", inv, "logs", "robot1", "sim", "-n", "5")
    assert r.returncode == 0 and "[sim]" in r.stdout, r.stdout


def _goal(fleet, master: str, goal: tuple[str, str, str]) -> subprocess.Popen:
    """``zenav goal`` from a process on the master host with the master's identity (its zenav.env)."""
    return on_host(fleet["hosts"], fleet["tmp"], master, ["-m", "deploy.cli", "goal", *goal, "--timeout", "150",
                                                           "--wait", "120", "--quiet"], seconds=300)


def _truth(fleet, masters: list[str]) -> dict[str, tuple[float, float]]:
    """Each simulator's ground truth (x, y), read on the master hosts (with their identity) at once."""
    procs = {m: on_host(fleet["hosts"], fleet["tmp"], m, ["-m", "deploy.cli", "topic", "echo", "ground_truth",
                                                          "-n", "1"], seconds=90) for m in masters}
    out = {}
    for m, p in procs.items():
        text = output(p, 120)
        found = re.search(r"pose=Transform\(translation=Vector3\(x=(\S+) y=(\S+) ", text)
        assert found, f"no ground truth from {m}: {text}"
        out[m] = float(found[1]), float(found[2])
    return out


def test_fleet_second_robot_with_its_own_master_a_goal_to_each(fleet):
    """robot2 + master2 (another robot name; install_mode link) join the running robot1 + master1 through
    an inventory of all four hosts. A goal to each robot at once: both reached (move_base SUCCEEDED and the
    simulators' ground truth). Then cmd_vel towards robot1 from the wrong identities does not move it.
    robot2 + master2 are stopped again."""
    inv2 = str(fleet["inv2"])
    t0, procs = time.monotonic(), []
    try:
        seed_kernels(fleet["tmp"] / "hosts/master2/zenav")
        r = zenav("fleet", "-i", inv2, "install", "robot2", "master2", timeout=600)
        assert r.returncode == 0, r.stdout + r.stderr
        r = zenav("fleet", "-i", inv2, "up", "robot2", "master2")
        assert r.returncode == 0, r.stdout + r.stderr
        goals = {"robot1": _goal(fleet, "master1", GOAL_B), "robot2": _goal(fleet, "master2", GOAL)}
        procs = list(goals.values())
        done = {rb: output(p, 320) for rb, p in goals.items()}
        print(f"both goals done {time.monotonic() - t0:.1f} s after the install started")
        for rb, p in goals.items():
            assert p.returncode == 0, f"{rb}: exit {p.returncode} {done[rb]}"
        truth = _truth(fleet, ["master1", "master2"])
        for rb, goal in (("robot1", GOAL_B), ("robot2", GOAL)):
            x, y = truth["master" + rb[-1]]
            print(f"{rb}: ground truth ({x:.2f}, {y:.2f}), goal {goal[:2]}")
            assert abs(x - float(goal[0])) < 0.4 and abs(y - float(goal[1])) < 0.4, (rb, x, y, goal)
        _wrong_cmd_vel_does_not_move_robot1(fleet, procs)
    finally:
        for p in procs:
            kill_group(p)
        zenav("fleet", "-i", inv2, "down", "robot2", "master2")
        print(f"second robot: {time.monotonic() - t0:.0f} s")


def _cmd_vel(fleet, host: str, args: list[str], **env: str) -> subprocess.Popen:
    """tests/fleet/cmd_vel_proc.py on ``host`` with its identity, towards robot1's cmd_vel."""
    return on_host(fleet["hosts"], fleet["tmp"], host, [str(HERE / "cmd_vel_proc.py"), *args],
                   env={"ZENAV_ROBOT": fleet["robot"], **env}, seconds=120)


def _wrong_cmd_vel_does_not_move_robot1(fleet, procs: list) -> None:
    """cmd_vel (0.3 m/s, 0.5 rad/s) towards robot1 for 2 s from master2's identity — at robot1's router
    (refused: not in its users file) and through master2's own router (not linked to robot1's) — and from
    robot1's own identity (authenticated, not a master: dropped by the access control). A counter on robot1
    sees none of it and the simulator's ground truth stays put; then master1's cmd_vel (a tiny 0.001 rad/s
    turn) does arrive."""
    t0 = time.monotonic()
    counter = _cmd_vel(fleet, "robot1", ["count", "100"], COUNT_UNTIL="0.0,0.001")
    procs.append(counter)
    assert counter.stdout.readline().strip() == "READY", output(counter)
    robot1 = f"tcp/{fleet['hosts'].address('robot1')}:7447"
    wrong = {"master2 at robot1's router": _cmd_vel(fleet, "master2", ["pub", "0.3", "0.5", "2"], ZENAV_CONNECT=robot1),
             "master2 through its router": _cmd_vel(fleet, "master2", ["pub", "0.3", "0.5", "2"]),
             "robot1's own identity": _cmd_vel(fleet, "robot1", ["pub", "0.3", "0.5", "2"])}
    procs += wrong.values()
    out = {k: output(p, 90) for k, p in wrong.items()}
    assert "REFUSED" in out["master2 at robot1's router"], out
    assert all("SENT" in out[k] for k in ("master2 through its router", "robot1's own identity")), out
    right = _cmd_vel(fleet, "master1", ["pub", "0.0", "0.001", "3"])  # after them: it ends the count
    procs.append(right)
    # the counter's result is its last JSON line; its log (stderr, after stdout here) may follow it, e.g. the
    # route watch's "route repaired" for its cmd_vel subscription (a CI run)
    text = output(counter, 100)
    line = next((ln for ln in reversed(text.splitlines()) if ln.startswith("{")), None)
    assert line is not None, f"the counter gave no result: {text}"
    res = json.loads(line)
    print(f"wrong cmd_vel: robot1 counted {res} ({time.monotonic() - t0:.1f} s)")
    assert "0.3,0.5" not in res["cmd_vel"], f"robot1 received cmd_vel from a wrong identity: {res}"
    assert res["cmd_vel"].get("0.0,0.001", 0) >= 10, f"master1's cmd_vel did not arrive: {res}; {output(right)}"
    assert res["moved"] < 0.05, res
    print(f"master1's cmd_vel: {output(right, 60).strip()!r}")  # ends by itself, or killed (a CI run found
    # it still running at `down`)


def test_fleet_status_finds_stopped_service_missing_node_and_clock_offset(fleet):
    inv, hosts = str(fleet["inv"]), fleet["hosts"]
    assert zenav("fleet", "-i", inv, "down", "master1").returncode == 0
    pid = node_pid(hosts, "robot1", "Pioneer3AT_laserscan_tf")
    os.kill(pid, 15)  # no respawn: stays missing
    wait_until(lambda: pid not in hosts.pids("robot1"), 30, "the static TF node gone")
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
    assert back < 90, lines[0]  # the robot agent and its nodes back (CPU-starved runs here: 45-60 s)
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

    for h in hosts.names:  # robot2 + master2 were stopped by their test
        left = [cmdline(p) for p in hosts.pids(h) if b"sshd" not in cmdline(p)]
        assert not left, f"processes left on {h}: {left}"
    r = zenav("fleet", "-i", str(fleet["inv"]), "status", "--seconds", "1")
    assert r.returncode == 1 and "inactive" in r.stdout
    print(f"fleet module: {time.monotonic() - T0:.0f} s")
