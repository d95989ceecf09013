"""`zenav monitor --robot '*' --save` with two synthetic robots on a private loopback bus (the monitor
connects to them only; no multicast): the recording holds both robots side by side, each robot's entities
under its own name and its TF frames prefixed the same way (two robots' ``map`` / ``odom`` / ``base_link``
frames must not mix). A prefix pattern (``pioneer*``) becomes the key expression ``zenav/pioneer$*/**``."""

from __future__ import annotations

import subprocess
import sys

import pytest
from monhelp import child_env, free_port, has_footer, read_rrd, values

from common.bus import Node
from common.zenoh_config import BusConfig
from testkit import synthetic_monitor as syn


@pytest.fixture
def two_robots(robot_name):
    """Two synthetic robots ``<robot_name>a`` and ``<robot_name>b``, each listening on its own port."""
    nodes, robots, eps = [], [], []
    try:
        for suffix in "ab":
            ep = f"tcp/127.0.0.1:{free_port()}"
            node = Node("synthetic", config=BusConfig(robot=robot_name + suffix, multicast=False, listen=(ep,)))
            nodes.append(node)
            robots.append(syn.SyntheticRobot(node, rate_hz=5.0, heavy_hz=1.0).start())
            eps.append(ep)
        yield [robot_name + s for s in "ab"], eps
    finally:
        for r in robots:
            r.close()
        for n in nodes:
            n.close()


@pytest.mark.parametrize("prefix", [False, True], ids=["all", "prefix"])
def test_monitor_shows_several_robots_side_by_side(tmp_path, robot_name, two_robots, prefix):
    names, eps = two_robots
    out = tmp_path / "fleet.rrd"
    env = child_env("unused", ",".join(eps))
    del env["ZENAV_ROBOT"]
    pattern = robot_name * prefix + "*"
    argv = [sys.executable, "-m", "deploy.cli", "monitor", "--robot", pattern, "--save", str(out), "--duration", "6"]
    r = subprocess.run(argv, env=env, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert "malformed=0 errors=0" in r.stderr, r.stderr
    assert has_footer(out)
    rec = read_rrd(out)

    roots = {e.split("/")[1] for e in rec if e.count("/") >= 2 and not e.startswith("/__")}
    assert roots == set(names), sorted(rec)
    assert not [e for e in rec if e.startswith(("/world/", "/tf/", "/plots/", "/log/"))], \
        "entities of a robot outside its own prefix"
    for name in names:
        for entity in ("world/map", "world/scan", "world/move_base/global_plan", "plots/cmd_vel/linear_x",
                       "log/move_base"):
            assert rec.get(f"/{name}/{entity}"), f"/{name}/{entity} missing; have {sorted(rec)}"
        frames = {v[0] for v in values(rec[f"/{name}/world/scan"], "CoordinateFrame:frame")}
        assert frames <= {f"{name}/odom", f"{name}/laser"} and f"{name}/odom" in frames  # placed at its stamp
        edges = {e: (values(rows, "Transform3D:parent_frame")[-1][0], values(rows, "Transform3D:child_frame")[-1][0])
                 for e, rows in rec.items() if e.startswith(f"/{name}/tf/")}
        assert edges[f"/{name}/tf/odom"] == (f"{name}/map", f"{name}/odom")
        assert edges[f"/{name}/tf/laser"] == (f"{name}/base_link", f"{name}/laser")  # latched, fetched
        assert values(rec[f"/{name}/world/robot"], "CoordinateFrame:frame")[-1][0] == f"{name}/base_link"


def test_monitor_pattern_refuses_the_web_page(robot_name):
    env = child_env("unused", f"tcp/127.0.0.1:{free_port()}")
    argv = [sys.executable, "-m", "deploy.cli", "monitor", "--robot", "*", "--serve-web", str(free_port())]
    r = subprocess.run(argv, env=env, capture_output=True, text=True, timeout=60)
    assert r.returncode != 0 and "--serve-web shows one robot" in r.stderr, r.stderr
