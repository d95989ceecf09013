"""move_base files: one including another (zenav), and the P3-AT's mapping files per sensor."""

from __future__ import annotations

from pathlib import Path

import pytest

from common.config import ConfigError


def test_a_move_base_file_includes_another_and_overrides_a_recoverys_keys_one_by_one(tmp_path):
    from master_side.move_base.config import load_move_base_config

    (tmp_path / "base.yaml").write_text(
        "controller_frequency: 5.0\nrecovery_behaviors: [{name: esc, type: zenav/EscapeRecovery}]\n"
        "esc: {speed: 0.05, max_distance: 0.2}\n")
    (tmp_path / "mine.yaml").write_text("include: base.yaml\nesc: {turn_then_drive: true}\n")
    c = load_move_base_config({"move_base": str(tmp_path / "mine.yaml")}, str(tmp_path / "master.yaml"))
    assert c.params.controller_frequency == 5.0
    assert c.recovery_namespaces["esc"] == {"speed": 0.05, "max_distance": 0.2, "turn_then_drive": True}
    (tmp_path / "bad.yaml").write_text("include: missing.yaml\n")
    with pytest.raises(ConfigError, match="missing.yaml"):
        load_move_base_config({"move_base": str(tmp_path / "bad.yaml")}, str(tmp_path / "master.yaml"))


def test_the_laser_p3at_maps_with_the_turn_then_drive_escape_and_the_kinect_without():
    """p3at_slam_zenav.yaml with deploy/stack/sensor_sets.py's values for each sensor, as the demo runs it."""
    from deploy.stack.sensor_sets import slam_sensor_sets
    from master_side import agent
    from master_side.move_base.config import load_move_base_config

    master = Path(__file__).resolve().parents[2] / "master_side/config/p3at_slam_zenav.yaml"
    for sensor, on in (("laser", True), ("kinect", False)):
        launch = agent.load(str(master), sets=slam_sensor_sets(sensor))
        c = load_move_base_config(*launch.node_params(launch.entry("move_base")))
        escapes = [b["name"] for b in c.params.recovery_behaviors if b["type"] == "zenav/EscapeRecovery"]
        assert escapes == ["escape", "escape_again"]
        assert all(bool(c.recovery_namespaces.get(n, {}).get("turn_then_drive", False)) is on for n in escapes), sensor


def test_includes_chain_relative_to_the_file_that_names_them_and_a_loop_is_refused(tmp_path):
    """A planner file may include one that includes another (a user's copy of zenav's mapping DWA file, which
    includes the P3-AT's): each path relative to the file naming it; the nearest file's keys win."""
    from master_side.move_base.config import load_move_base_config

    (tmp_path / "p3at").mkdir()
    (tmp_path / "p3at/dwa.yaml").write_text("DWAPlannerROS: {max_vel_x: 0.55, min_vel_x: -0.1, sim_time: 1.7}\n")
    (tmp_path / "p3at/dwa_slam.yaml").write_text("DWAPlannerROS: {include: dwa.yaml, min_vel_x: 0.0}\n")
    (tmp_path / "mine.yaml").write_text("DWAPlannerROS: {include: p3at/dwa_slam.yaml, max_vel_x: 0.3}\n")
    mb = tmp_path / "mb.yaml"
    mb.write_text("base_local_planner: dwa_local_planner/DWAPlannerROS\n")
    c = load_move_base_config({"move_base": str(mb), "local_planner": str(tmp_path / "mine.yaml")},
                              str(tmp_path / "master.yaml"))
    assert (c.local_params.max_vel_x, c.local_params.min_vel_x, c.local_params.sim_time) == (0.3, 0.0, 1.7)
    (tmp_path / "p3at/dwa.yaml").write_text("DWAPlannerROS: {include: ../mine.yaml}\n")
    with pytest.raises(ConfigError, match=r"already in this chain of includes: .*mine.yaml -> .*dwa_slam.yaml -> "
                                          r".*dwa.yaml -> .*mine.yaml"):
        load_move_base_config({"move_base": str(mb), "local_planner": str(tmp_path / "mine.yaml")},
                              str(tmp_path / "master.yaml"))
    (tmp_path / "a.yaml").write_text("include: b.yaml\ncontroller_frequency: 4.0\n")
    (tmp_path / "b.yaml").write_text("include: c.yaml\n")
    (tmp_path / "c.yaml").write_text("controller_frequency: 9.0\nplanner_patience: 3.0\n")
    c = load_move_base_config({"move_base": str(tmp_path / "a.yaml")}, str(tmp_path / "master.yaml"))
    assert (c.params.controller_frequency, c.params.planner_patience) == (4.0, 3.0)
