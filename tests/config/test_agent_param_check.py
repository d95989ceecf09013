"""The agents check every node's parameters before starting anything: all errors in one message and
exit 2 with nothing spawned; parameters without effect listed once, per node, as a warning."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import yaml

from common.launch import Section, load_launch
from common.node_check import check_nodes, format_notes
from tests.agent.conftest import REPO, agents, bus, read_events, wait_until  # noqa: F401 (fixtures)

PLAIN, CHECKED = "tests.agent.plain_node", "tests.config.checked_node"
ROOM_MAP = str(REPO / "master_side" / "config" / "maps" / "room.yaml")


def write(tmp_path: Path, data: dict, name: str = "master.yaml") -> Path:
    p = tmp_path / name
    p.write_text(yaml.safe_dump(data, sort_keys=False))
    return p


def test_master_agent_with_errors_in_two_nodes_exits_2_naming_both_and_starts_nothing(tmp_path, robot_name):
    log = tmp_path / "ev.log"
    cfg = write(tmp_path, {"nodes": {
        "witness": {"module": PLAIN, "params": {"log": str(log)}},
        "map_server": {"module": "master_side.mapping.map_server_node",
                       "params": {"map": ROOM_MAP, "frame_idd": "map"}},
        "localization": {"module": "master_side.localization.amcl_node",
                         "params": {"min_particles": 0, "laser_z_short": 0.1}}}})
    env = {**os.environ, "PYTHONPATH": str(REPO), "ZENAV_MULTICAST": "0"}
    r = subprocess.run([sys.executable, "-m", "master_side.agent", "--config", str(cfg), "--robot", robot_name],
                       capture_output=True, text=True, cwd=REPO, env=env, timeout=120)
    assert r.returncode == 2, r.stderr
    src = str(cfg.resolve())
    assert f"{src}: nodes.map_server.params.frame_idd: unknown key; did you mean 'frame_id'?" in r.stderr
    assert f"{src}: nodes.localization.params.min_particles: 0 is out of range" in r.stderr
    assert "config error (2 problems; nothing started)" in r.stderr
    assert not log.exists()                     # the witness node never ran
    assert "[witness]" not in r.stdout + r.stderr


def test_no_effect_parameters_are_grouped_per_node_in_one_warning(tmp_path):
    cfg = write(tmp_path, {"nodes": {
        "map_server": {"module": "master_side.mapping.map_server_node", "params": {"map": ROOM_MAP}},
        "localization": {"module": "master_side.localization.amcl_node",
                         "params": {"laser_z_short": 0.1, "do_beamskip": True, "min_particles": 50}},
        "slam": {"module": "master_side.slam.node", "params": {"throttle_scans": 1, "particles": 5}},
        "plain": {"module": PLAIN}}})
    launch = load_launch(cfg, [Section("nodes")])
    notes = check_nodes(launch)
    src = str(cfg.resolve())
    assert notes["map_server"] == [] and notes["plain"] == []
    assert notes["localization"] == [f"{src}: nodes.localization.params.laser_z_short: no effect (not implemented "
                                     "in zenav)", f"{src}: nodes.localization.params.do_beamskip: no effect (not "
                                     "implemented in zenav)"]
    assert notes["slam"] == [f"{src}: nodes.slam.params.throttle_scans: no effect (not implemented in zenav)"]
    why = "no effect (not implemented in zenav)"
    assert format_notes("master", notes).splitlines() == [
        "zenav master: warning: 3 parameters accepted with no effect:",
        "  localization:", f"    {src}:",
        f"      nodes.localization.params.laser_z_short, nodes.localization.params.do_beamskip: {why}",
        "  slam:", f"    {src}:", f"      nodes.slam.params.throttle_scans: {why}"]


def test_agent_prints_the_warning_once_then_starts_its_nodes(bus, agents, robot_name, tmp_path):  # noqa: F811
    node, env = bus
    log = tmp_path / "ev.log"
    cfg = {"nodes": {"a": {"module": CHECKED, "params": {"log": str(log), "unused": ["publish_traj_pc"]}},
                     "b": {"module": CHECKED, "params": {"log": str(log), "unused": ["sum_scores", "cheat_factor"]}}}}
    agent = agents(cfg, robot_name, env, kind="master")
    wait_until(lambda: {n for e, n, _, _ in read_events(log) if e == "start"} == {"a", "b"}, 60, "both started")
    agent.proc.send_signal(signal.SIGTERM)
    assert agent.wait(60) == 0
    err = agent.stderr()
    src, why = agent.config.resolve(), "no effect (not implemented in zenav)"
    block = ["zenav master: warning: 3 parameters accepted with no effect:",
             "  a:", f"    {src}:", f"      nodes.a.params.publish_traj_pc: {why}",
             "  b:", f"    {src}:", f"      nodes.b.params.sum_scores, nodes.b.params.cheat_factor: {why}"]
    assert "\n".join(block) in err
    assert err.count("accepted with no effect") == 1
    assert err.index(block[0]) < err.index("zenav master: robot")   # before the nodes are started


def test_robot_agent_reports_every_node_error_together(tmp_path, robot_name):
    cfg = write(tmp_path, {"platform": {"base": {"module": CHECKED, "params": {"bad": ["port"]}}},
                           "sensors": {"laser": {"module": CHECKED, "params": {"bad": ["range_max", "frame"]}},
                                       "ghost": {"module": "tests.config.no_such_module"}}}, "robot.yaml")
    env = {**os.environ, "PYTHONPATH": str(REPO), "ZENAV_MULTICAST": "0"}
    r = subprocess.run([sys.executable, "-m", "robot_side.agent", "--config", str(cfg), "--robot", robot_name],
                       capture_output=True, text=True, cwd=REPO, env=env, timeout=120)
    assert r.returncode == 2, r.stderr
    src = str(cfg.resolve())
    for key in ("platform.base.params.port", "sensors.laser.params.range_max", "sensors.laser.params.frame"):
        assert f"{src}: {key}: not a good value" in r.stderr
    assert f"{cfg}: sensors.ghost.module: cannot import 'tests.config.no_such_module'" in r.stderr
    assert "config error (4 problems; nothing started)" in r.stderr
