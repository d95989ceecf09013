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
