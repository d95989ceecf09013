"""``zenav fleet`` without hosts: the inventory's validation (file / key / why), the rendered files
(env, Zenoh config with the cmd_vel access control, units), --dry-run, and the pidfile supervisor."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

from common.config_errors import ConfigError
from deploy.fleet import inventory, render

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "deploy" / "hosts" / "fleet.example.yaml"


def _example(tmp_path: Path, **changes) -> Path:
    data = yaml.safe_load(EXAMPLE.read_text())
    data["defaults"]["ssh"].pop("key")  # ~/.ssh/id_ed25519 may not exist here
    for k, v in changes.items():
        data[k] = v
    p = tmp_path / "fleet.yaml"
    p.write_text(yaml.safe_dump(data, sort_keys=False))
    return p


def test_example_inventory_loads(tmp_path):
    inv = inventory.load(_example(tmp_path))
    assert inv.names() == ["robot1", "master1", "robot2", "master2", "hub"]
    assert [h.name for h in inv.select()][0] == "hub"  # routers start first
    r1 = inv.host("robot1")
    assert (r1.role, r1.robot, r1.ssh.user, r1.install_dir) == ("robot", "pioneer1", "root", "/opt/zenav")
    assert r1.labels == (("model", "p3at"), ("site", "lab"))
    assert inv.host("robot2").zenoh.router == "hub"
    with pytest.raises(ConfigError, match="hosts.robot: no such host; did you mean"):
        inv.host("robot")


def test_every_problem_is_reported_with_file_key_why(tmp_path):
    p = tmp_path / "bad.yaml"
    p.write_text(yaml.safe_dump({"hosts": {
        "r1": {"address": "10.0.0.1", "role": "robto", "robot": "p", "config": "robot_side/config/p3at_sim.yaml"},
        "m1": {"role": "master", "robot": "p", "config": "nope.yaml", "zenoh": {"mode": "client"}},
        "c1": {"address": "10.0.0.3", "role": "robot", "robot": "p", "config": "robot_side/config/p3at_sim.yaml",
               "zenoh": {"router": "m1", "lease_ms": 10}, "instal_dir": "/x", "ssh": {"port": 70000}},
    }}))
    with pytest.raises(ConfigError) as e:
        inventory.load(p)
    text = str(e.value)
    expected = ["hosts.r1.role: must be one of robot, master, router, got 'robto'",
                "hosts.m1.address: missing", "hosts.m1.config:", "no such file in this checkout",
                "hosts.m1.zenoh.mode: a client needs router:", "hosts.c1.zenoh.lease_ms: must be >= 100",
                "hosts.c1.instal_dir: unknown key; did you mean 'install_dir'",
                "hosts.c1.ssh.port: must be 1..65535",
                "hosts.c1.zenoh.router: 'm1' is not a host with role: router"]
    for want in expected:
        assert want in text, f"{want!r} not in:\n{text}"
    assert all(line.startswith(str(p) + ": ") for line in text.splitlines())


def test_env_file_and_units(tmp_path):
    inv = inventory.load(_example(tmp_path))
    env = render.env_file(inv, inv.host("robot2"))
    assert "ZENAV_ROBOT=pioneer2" in env and "ZENAV_MODE=client" in env
    assert "ZENAV_CONNECT=tcp/192.168.1.2:7447" in env and "ZENAV_MULTICAST=0" in env
    unit = render.unit(inv.host("master1"))
    assert ("ExecStart=/opt/zenav/venv/bin/zenav master --config "
            "/opt/zenav/src/master_side/config/p3at_amcl.yaml") in unit
    assert "EnvironmentFile=/opt/zenav/etc/zenav.env" in unit and "RestartPreventExitStatus=2" in unit
    router = json.loads(render.service_spec(inv.host("hub")))
    assert router["argv"][1:] == ["zenoh", "router", "--config", "/opt/zenav/etc/router.json5"]
    rules = render.udev_rules(inv.host("robot1"))  # udev_adapter: ftdi
    assert 'ATTRS{idVendor}=="0403"' in rules and 'ATTRS{idVendor}=="067b"' not in rules


def test_cmd_vel_acl_gives_each_robot_and_master_a_router_with_usrpwd_and_access_control(tmp_path):
    import zenoh

    data = yaml.safe_load(EXAMPLE.read_text())
    data["defaults"]["ssh"].pop("key")
    data["security"] = {"cmd_vel_acl": True, "secrets_dir": "secrets"}
    for name in ("robot2", "master2"):  # no shared router with the access control (checked below)
        data["hosts"][name].pop("zenoh")
    (tmp_path / "fleet.yaml").write_text(yaml.safe_dump(data, sort_keys=False))
    inv = inventory.load(tmp_path / "fleet.yaml")
    robot, master = inv.host("robot1"), inv.host("master1")
    users = render.users_txt(inv, robot)
    assert [line.split(":")[0] for line in users.splitlines()] == ["master1", "robot1"]  # not master2
    assert render.users_txt(inv, master).split(":")[0] == "master1"  # its own processes accept each other
    rrouter = _json_body(render.router_json(inv, robot))  # the robot's router holds the access control
    assert rrouter["mode"] == "router" and rrouter["listen"]["endpoints"] == ["tcp/0.0.0.0:7447"]
    assert rrouter["access_control"]["subjects"][1]["usernames"] == ["master1"]
    assert rrouter["transport"]["auth"]["usrpwd"]["dictionary_file"] == "/opt/zenav/etc/users.txt"
    assert "endpoints" not in rrouter.get("connect", {})  # the robot opens no link
    mrouter = _json_body(render.router_json(inv, master))  # the master's router opens the link: usrpwd names it
    assert mrouter["connect"]["endpoints"] == ["tcp/192.168.1.21:7447"] and "access_control" not in mrouter
    assert mrouter["transport"]["auth"]["usrpwd"]["user"] == "master1"
    assert mrouter["transport"]["auth"]["usrpwd"]["password"] == users.splitlines()[0].split(":", 1)[1]
    mclient = _json_body(render.zenoh_json(inv, master))  # every process on the host: a client of its router
    assert mclient["mode"] == "client" and mclient["connect"]["endpoints"] == ["tcp/127.0.0.1:7447"]
    assert mclient["transport"]["auth"]["usrpwd"]["user"] == "master1"
    for h in (robot, master):
        env = render.env_file(inv, h)
        assert "ZENAV_MODE=client" in env and "ZENAV_CONNECT=tcp/127.0.0.1:7447" in env, env
        assert "ZENAV_LISTEN" not in env and "ZENAV_MULTICAST=0" in env
        spec = json.loads(render.service_spec(h, own_router=True))
        assert spec["argv"][1:5] == ["-m", "deploy.fleet.host_router", "/opt/zenav/etc/router.json5", "--"]
        assert spec["argv"][6] == h.role
    assert render.router_json(inv, inv.host("hub")) is None
    assert render.users_txt(inv, robot) == users  # passwords kept: re-installs are idempotent
    for conf in (rrouter, mrouter, mclient):
        zenoh.Config.from_json5(json.dumps(conf))  # zenoh accepts them


def test_cmd_vel_acl_refuses_a_shared_router_and_two_routers_on_one_port(tmp_path):
    p = _example(tmp_path, security={"cmd_vel_acl": True})
    with pytest.raises(ConfigError) as e:
        inventory.load(p)
    assert "hosts.robot2.zenoh.router: with security.cmd_vel_acl every robot and master runs its own" in str(e.value)
    data = yaml.safe_load(p.read_text())
    for name in ("robot2", "master2"):
        data["hosts"][name] = {**data["hosts"][name], "address": "192.168.1.21"}
        data["hosts"][name].pop("zenoh")
    p.write_text(yaml.safe_dump(data))
    with pytest.raises(ConfigError, match="hosts.robot2.zenoh.listen: 192.168.1.21 port 7447 is the router port "
                                          "of robot1 too"):
        inventory.load(p)


def _json_body(text: str) -> dict:
    return json.loads("\n".join(line for line in text.splitlines() if not line.startswith("//")))


def test_dry_run_prints_every_command_and_does_nothing(tmp_path):
    p = _example(tmp_path)
    r = subprocess.run([sys.executable, "-m", "deploy.cli", "fleet", "-i", str(p), "install", "--dry-run",
                        "robot1"], cwd=REPO, capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    out = r.stdout
    for want in ("root@192.168.1.21", "-m venv --system-site-packages /opt/zenav/venv", "pip install",
                 "git ls-files | tar cz", "write /opt/zenav/etc/zenav.env",
                 "write /etc/udev/rules.d/99-pioneer.rules",
                 "write /etc/systemd/system/zenav-robot.service", "systemctl daemon-reload"):
        assert want in out, want
    r = subprocess.run([sys.executable, "-m", "deploy.cli", "fleet", "-i", str(tmp_path / "missing.yaml"), "up"],
                       cwd=REPO, capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "missing.yaml: (file): cannot read" in r.stderr


def _running(pid: int) -> bool:
    """Alive and not a zombie (PID 1 here may not reap orphans)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def test_supervisor_restarts_on_failure_not_on_bad_config_and_stops(tmp_path):
    sup = REPO / "deploy" / "fleet" / "supervise.py"
    marker = tmp_path / "runs"
    script = f"import sys; open({str(marker)!r}, 'a').write('x'); import time; " \
             f"sys.exit(1) if len(open({str(marker)!r}).read()) < 2 else time.sleep(60)"
    spec = {"name": "svc", "argv": [sys.executable, "-c", script], "cwd": str(tmp_path), "env_file": "",
            "log": str(tmp_path / "log/svc.log"), "run_dir": str(tmp_path / "run"), "restart_sec": 0.2,
            "stop_timeout": 5, "no_restart_exit": [2]}
    (tmp_path / "svc.json").write_text(json.dumps(spec))

    def sv(verb: str) -> str:
        return subprocess.run([sys.executable, str(sup), verb, str(tmp_path / "svc.json")], capture_output=True,
                              text=True, timeout=30).stdout

    assert "started" in sv("start")
    deadline = time.monotonic() + 20
    while (json.loads(sv("status")).get("restarts"), json.loads(sv("status"))["state"]) != (1, "active") \
            and time.monotonic() < deadline:
        time.sleep(0.1)
    st = json.loads(sv("status"))
    assert st["state"] == "active" and st["restarts"] == 1, st  # failed once, restarted, now running
    assert "already running" in sv("start")
    child = st["child_pid"]
    assert "stopped" in sv("stop")
    assert json.loads(sv("status"))["state"] == "inactive"
    assert not _running(child), "the service outlived its supervisor's stop"
    spec["argv"] = [sys.executable, "-c", "import sys; sys.exit(2)"]  # bad config: not restarted
    (tmp_path / "svc.json").write_text(json.dumps(spec))
    sv("start")
    deadline = time.monotonic() + 20
    while json.loads(sv("status"))["state"] != "failed" and time.monotonic() < deadline:
        time.sleep(0.1)
    st = json.loads(sv("status"))
    assert st["state"] == "failed" and st["last_exit"] == 2 and st["restarts"] == 0, st


def test_status_report_names_each_problem_and_its_fix():
    from deploy.fleet.inventory import Host
    from deploy.fleet.status import HostStatus, evaluate, report

    robot = HostStatus(Host("r1", "10.0.0.1", "robot", "p", "robot_side/config/p3at_sim.yaml"),
                       service={"state": "active", "manager": "supervisor", "pid": 3},
                       probe={"nodes": ["robot_agent"], "rates": {"odom": 10.0, "scan": 0.0}},
                       expected=["robot_agent", "sim"], clock=0.21, clock_rtt=0.004)
    master = HostStatus(Host("m1", "10.0.0.2", "master", "p", "x.yaml"), service={"state": "failed"},
                        clock=0.0, clock_rtt=0.004)
    evaluate([robot, master])
    text, bad = report([robot, master])
    assert bad == 4, text
    for want in ("r1: FAIL  nodes: missing sim", "fix: zenav fleet logs r1 sim", "r1: FAIL  topic scan: 0.0 Hz",
                 "r1: WARN  clock: +210 ms", "chrony", "m1: FAIL  service: zenav-master failed",
                 "fix: zenav fleet up m1", "+210ms"):
        assert want in text, want


def test_rendered_units_pass_systemd_analyze_verify(tmp_path):
    import shutil

    if shutil.which("systemd-analyze") is None:
        pytest.skip("systemd-analyze not installed")
    data = yaml.safe_load(EXAMPLE.read_text())
    data["defaults"]["ssh"].pop("key")
    data["defaults"]["install_dir"] = str(tmp_path / "zenav")
    (tmp_path / "fleet.yaml").write_text(yaml.safe_dump(data, sort_keys=False))
    inv = inventory.load(tmp_path / "fleet.yaml")
    for exe in ("zenav", "python"):  # the secured units start the venv's python (host_router)
        f = Path(render.paths(inv.host("robot1"))[exe])
        f.parent.mkdir(parents=True, exist_ok=True)
        f.write_text("#!/bin/sh\n")
        f.chmod(0o755)
    (tmp_path / "zenav" / "src").mkdir()
    units = []
    for name, own_router in (("robot1", False), ("master1", False), ("hub", False), ("robot1", True)):
        h = inv.host(name)
        units.append(tmp_path / "units" / f"{h.service}{'-secured' if own_router else ''}.service")
        units[-1].parent.mkdir(exist_ok=True)
        units[-1].write_text(render.unit(h, own_router))
    v = subprocess.run(["systemd-analyze", "verify", *map(str, units)], capture_output=True, text=True, timeout=120)
    assert v.returncode == 0, v.stderr


def test_status_names_a_master_that_does_not_reach_its_running_robot():
    from deploy.fleet.inventory import Host
    from deploy.fleet.status import HostStatus, evaluate, report

    def statuses(master_sees: list[str]) -> list[HostStatus]:
        up = {"state": "active", "manager": "supervisor", "pid": 3}
        return [HostStatus(Host("r1", "10.0.0.1", "robot", "p", "x.yaml"), service=up,
                           probe={"nodes": ["robot_agent", "sim"]}, expected=["robot_agent", "sim"]),
                HostStatus(Host("m1", "10.0.0.2", "master", "p", "y.yaml"), service=up,
                           probe={"nodes": ["master_agent", *master_sees]}, expected=["master_agent"])]

    unlinked = statuses([])
    evaluate(unlinked)
    text, bad = report(unlinked)
    assert bad == 1 and "m1: FAIL  link: robot p's nodes run but are not seen from m1" in text, text
    linked = statuses(["robot_agent", "sim"])
    evaluate(linked)
    assert report(linked)[1] == 0


def test_a_nodes_log_lines_are_picked_before_the_last_ones_are_counted(tmp_path):
    """`zenav fleet logs HOST NODE -n 5` on a supervised host (no systemd): the shell line, run by bash on a
    real log file, prints the node's own last 5 lines even when other nodes logged after them (it printed
    nothing, exit 1, when it took the log's last 5 lines first); without a node, the log's last 5."""
    import dataclasses

    from deploy.fleet.inventory import Host
    from deploy.fleet.render import paths
    from deploy.fleet.services import log_command
    from deploy.fleet.ssh import Remote

    host = dataclasses.replace(Host("r1", "10.0.0.1", "robot", "p", "x.yaml"), install_dir=str(tmp_path),
                               service_manager="supervisor")
    log = Path(paths(host)["log"]) / f"{host.service}.log"
    log.parent.mkdir(parents=True)
    lines = [f"[sim] step {i}" for i in range(8)] + [f"[move_base] cycle {i}" for i in range(20)]
    log.write_text("\n".join(lines) + "\n")

    def run(node: str) -> subprocess.CompletedProcess:
        return subprocess.run(["bash", "-c", log_command(Remote(host), node, 5)], capture_output=True, text=True)

    sim = run("sim")
    assert sim.returncode == 0 and sim.stdout.splitlines() == [f"[sim] step {i}" for i in range(3, 8)], sim
    assert run("").stdout.splitlines() == lines[-5:]
    assert run("amcl").stdout == ""  # a node that logged nothing: nothing printed
