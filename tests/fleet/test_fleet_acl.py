"""The access control ``zenav fleet`` generates (``security: {cmd_vel_acl: true}``), live on loopback:
processes with the hosts' generated zenav.env / zenoh.json5 / users.txt. robot1's cmd_vel arrives from
its own master, is refused from master2 (another robot's master: not in robot1's users file) and dropped
from an authenticated peer that is not a master (robot1's own identity: the access control, not only
the authentication). A process per role, not the full agents (see docs/fleet.md)."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import yaml

from deploy import free_port
from deploy.fleet import inventory, render

HERE = Path(__file__).resolve().parent
PROC = HERE / "acl_proc.py"


def _write_host_files(inv, h) -> None:
    p = render.paths(h)
    files = {p["env"]: render.env_file(inv, h), p["zenoh"]: render.zenoh_json(inv, h),
             p["users"]: render.users_txt(inv, h)}
    for path, text in files.items():
        if text is not None:
            Path(path).parent.mkdir(parents=True, exist_ok=True)
            Path(path).write_text(text)


def test_generated_acl_lets_only_the_robots_own_master_publish_cmd_vel(tmp_path, robot_name):
    ports = {"robot1": free_port(), "robot2": free_port()}

    def host(name: str, role: str, robot: str) -> dict:
        d = {"address": "127.0.0.1", "role": role, "robot": robot, "install_dir": str(tmp_path / name),
             "config": "robot_side/config/p3at_sim.yaml" if role == "robot" else
             "master_side/config/p3at_known_map.yaml", "zenoh": {"shared_memory": False}}
        if role == "robot":
            d["zenoh"]["listen"] = [f"tcp/127.0.0.1:{ports[name]}"]
        return d

    r1, r2 = robot_name + "a", robot_name + "b"
    data = {"security": {"cmd_vel_acl": True, "secrets_dir": str(tmp_path / "secrets")},
            "hosts": {"robot1": host("robot1", "robot", r1), "master1": host("master1", "master", r1),
                      "robot2": host("robot2", "robot", r2), "master2": host("master2", "master", r2)}}
    (tmp_path / "fleet.yaml").write_text(yaml.safe_dump(data, sort_keys=False))
    inv = inventory.load(tmp_path / "fleet.yaml")
    for h in inv.hosts:
        _write_host_files(inv, h)
    env_file = {h.name: render.paths(h)["env"] for h in inv.hosts}
    assert f"ZENAV_CONNECT=tcp/127.0.0.1:{ports['robot1']}" in Path(env_file["master1"]).read_text()

    base = {k: v for k, v in os.environ.items() if not k.startswith("ZENAV_")}
    key = f"zenav/{r1}/cmd_vel"
    procs: list[subprocess.Popen] = []

    def start(name: str, role: str, text: str = "", **extra: str) -> subprocess.Popen:
        p = subprocess.Popen([sys.executable, str(PROC), env_file[name], role, key, *([text] if text else [])],
                             env={**base, **extra}, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        procs.append(p)
        return p

    def lines(p: subprocess.Popen, until, timeout: float) -> list[str]:
        out, deadline = [], time.monotonic() + timeout
        os.set_blocking(p.stdout.fileno(), False)
        while time.monotonic() < deadline and not until(out):
            line = p.stdout.readline()
            if line:
                out.append(line.strip())
            else:
                time.sleep(0.02)
        return out

    robot1 = f"tcp/127.0.0.1:{ports['robot1']}"
    try:
        robot = start("robot1", "sub")
        assert "READY" in lines(robot, lambda o: "READY" in o, 30)
        intruder = start("robot1", "pub", "intruder", ZENAV_LISTEN="tcp/127.0.0.1:0", ZENAV_CONNECT=robot1)
        wrong = start("master2", "pub", "master2", ZENAV_CONNECT=robot1)
        got = lines(intruder, lambda o: any(x.startswith("PEERS") for x in o), 20)
        assert any(x.startswith("PEERS") for x in got), f"the intruder did not connect: {got}"
        right = start("master1", "pub", "master1")
        seen = lines(robot, lambda o: sum(x == "GOT master1" for x in o) >= 20, 40)
        assert sum(x == "GOT master1" for x in seen) >= 20, seen[-5:]
        assert "GOT intruder" not in seen and "GOT master2" not in seen, sorted(set(seen))
        wrong_out = lines(wrong, lambda o: False, 0.5)
        assert not any(x.startswith("PEERS") for x in wrong_out), "master2 was let in by robot1"
        assert right.poll() is None
    finally:
        for p in procs:
            p.kill()
            p.wait(timeout=10)
