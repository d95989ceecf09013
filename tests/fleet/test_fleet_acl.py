"""The secured topology ``zenav fleet`` generates (``security: {cmd_vel_acl: true}``), live on loopback:
each host's router (``deploy.fleet.host_router`` with its router.json5 / users.txt) and a process per
host as its client (zenav.env / zenoh.json5). robot1's cmd_vel arrives from its own master (through
master1's router, linked to robot1's), is refused from master2's identity (not in robot1's users file),
does not reach robot1 through master2's own router (no link) and is dropped from an authenticated client
that is not a master (robot1's own identity: the access control, not only the authentication). A process
per role, not the full agents (tests/fleet/test_fleet_netns.py runs those)."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import yaml

from common.ports import free_port
from deploy.fleet import inventory, render

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
PROC = HERE / "acl_proc.py"


def _write_host_files(inv, h) -> None:
    p = render.paths(h)
    files = {p["env"]: render.env_file(inv, h), p["zenoh"]: render.zenoh_json(inv, h),
             p["router"]: render.router_json(inv, h), p["users"]: render.users_txt(inv, h)}
    for path, text in files.items():
        if text is not None:
            Path(path).parent.mkdir(parents=True, exist_ok=True)
            Path(path).write_text(text)


def test_generated_acl_lets_only_the_robots_own_master_publish_cmd_vel(tmp_path, robot_name):
    names = ("robot1", "master1", "robot2", "master2")
    ports = {n: free_port() for n in names}  # one address: each host's router on its own port

    def host(name: str, role: str, robot: str) -> dict:
        return {"address": "127.0.0.1", "role": role, "robot": robot, "install_dir": str(tmp_path / name),
                "config": "robot_side/config/p3at_sim.yaml" if role == "robot" else
                "master_side/config/p3at_known_map.yaml",
                "zenoh": {"shared_memory": False, "listen": [f"tcp/127.0.0.1:{ports[name]}"]}}

    r1, r2 = robot_name + "a", robot_name + "b"
    data = {"security": {"cmd_vel_acl": True, "secrets_dir": str(tmp_path / "secrets")},
            "hosts": {n: host(n, "robot" if n.startswith("robot") else "master", r1 if n[-1] == "1" else r2)
                      for n in names}}
    (tmp_path / "fleet.yaml").write_text(yaml.safe_dump(data, sort_keys=False))
    inv = inventory.load(tmp_path / "fleet.yaml")
    for h in inv.hosts:
        _write_host_files(inv, h)
    env_file = {h.name: render.paths(h)["env"] for h in inv.hosts}
    router_file = {h.name: render.paths(h)["router"] for h in inv.hosts}
    assert f"ZENAV_CONNECT=tcp/127.0.0.1:{ports['master1']}" in Path(env_file["master1"]).read_text()

    base = {k: v for k, v in os.environ.items() if not k.startswith("ZENAV_")}
    key = f"zenav/{r1}/cmd_vel"
    procs: list[subprocess.Popen] = []

    def start(name: str, role: str, text: str = "", router: bool = False, **extra: str) -> subprocess.Popen:
        argv = [sys.executable, str(PROC), env_file[name], role, key, *([text] if text else [])]
        if router:  # as the service runs it: the host's router, then the process as its client
            argv = [sys.executable, "-m", "deploy.fleet.host_router", router_file[name], "--", *argv]
        env = {**base, "PYTHONPATH": str(REPO), **extra}
        p = subprocess.Popen(argv, cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        procs.append(p)
        return p

    def lines(p: subprocess.Popen, until, timeout: float) -> list[str]:
        out, deadline = [], time.monotonic() + timeout
        os.set_blocking(p.stdout.fileno(), False)
        while time.monotonic() < deadline and not until(out):
            line = p.stdout.readline()
            if line:
                out.append(line.strip())
            elif p.poll() is not None:
                break
            else:
                time.sleep(0.02)
        return out

    robot1 = f"tcp/127.0.0.1:{ports['robot1']}"
    try:
        robot = start("robot1", "sub", router=True)
        assert "READY" in lines(robot, lambda o: "READY" in o, 30)
        intruder = start("robot1", "pub", "intruder")  # authenticated (robot1's identity), not a master
        wrong = start("master2", "pub", "master2", ZENAV_CONNECT=robot1)  # master2's identity at robot1's router
        elsewhere = start("master2", "pub", "master2-router", router=True)  # master2's own router: no link there
        got = lines(intruder, lambda o: any(x.startswith("PEERS") for x in o), 20)
        assert any(x.startswith("PEERS") for x in got), f"the intruder did not connect: {got}"
        right = start("master1", "pub", "master1", router=True)
        seen = lines(robot, lambda o: sum(x == "GOT master1" for x in o) >= 20, 40)
        assert sum(x == "GOT master1" for x in seen) >= 20, seen[-5:]
        assert not {"GOT intruder", "GOT master2", "GOT master2-router"} & set(seen), sorted(set(seen))
        wrong_out = lines(wrong, lambda o: False, 0.5)
        assert wrong.poll() not in (None, 0) and not any(x.startswith("PEERS") for x in wrong_out), \
            f"master2 was let in by robot1's router: {wrong_out[-3:]}"
        assert right.poll() is None and elsewhere.poll() is None
    finally:
        for p in procs:
            p.kill()
            p.wait(timeout=10)
