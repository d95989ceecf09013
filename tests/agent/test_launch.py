"""Launch-file loading for the robot and master agents (no processes)."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from common.config import ConfigError
from master_side.agent import load as load_master
from robot_side.agent import load as load_robot

REPO = Path(__file__).resolve().parents[2]


def write(tmp_path: Path, data: dict, name: str = "r.yaml") -> str:
    p = tmp_path / name
    p.write_text(yaml.safe_dump(data, sort_keys=False))
    return str(p)


def test_unknown_section_names_file_and_section(tmp_path):
    path = write(tmp_path, {"platform": {"b": {"module": "x"}}, "sensorz": {}})
    with pytest.raises(ConfigError) as e:
        load_robot(path)
    assert path in str(e.value)
    assert "sensorz" in str(e.value)


def test_unknown_node_key_names_file_and_dotted_key(tmp_path):
    path = write(tmp_path, {"sensors": {"laser": {"module": "x", "respwan": True}}})
    with pytest.raises(ConfigError) as e:
        load_robot(path)
    assert e.value.source == path
    assert e.value.key == "sensors.laser.respwan"


@pytest.mark.parametrize(("body", "key"), [
    ({"sensors": {"a": {"module": "x", "after": ["nope"]}}}, "sensors.a.after"),
    ({"sensors": {"a": {"module": "x", "respawn": "yes"}}}, "sensors.a.respawn"),
    ({"sensors": {"a": {"module": "x", "cmd": ["y"]}}}, "sensors.a"),
    ({"sensors": {"a b": {"module": "x"}}}, "sensors.a b"),
    ({"sensors": {"a": {"module": "x", "after": ["b"]}, "b": {"module": "x", "after": ["a"]}}}, "<nodes>"),
    ({"supervisor": {"grace": -1}, "sensors": {"a": {"module": "x"}}}, "supervisor.grace"),
    ({"transforms": {"t": {"parent": "base_link"}}}, "transforms.t"),
    ({"robot": "a/b", "sensors": {"a": {"module": "x"}}}, "robot"),
])
def test_invalid_entries_raise_with_their_key(tmp_path, body, key):
    path = write(tmp_path, body)
    with pytest.raises(ConfigError) as e:
        load_robot(path)
    assert e.value.key == key, str(e.value)


def test_params_in_the_file_are_passed_as_a_section_of_the_file(tmp_path):
    path = write(tmp_path, {"sensors": {"laser": {"module": "m.laser", "params": {"range_max": 4.0}}}})
    (spec,) = load_robot(path).specs(str(tmp_path / "gen"))
    assert spec.config == str(Path(path).resolve())
    assert spec.section == "sensors.laser.params"
    assert spec.argv()[1:3] == ["-m", "m.laser"]


def test_platform_nodes_stop_first_by_default_and_can_opt_out(tmp_path):
    path = write(tmp_path, {"platform": {"base": {"module": "b"},
                                         "enable": {"module": "e", "stop_first": False}},
                            "sensors": {"laser": {"module": "l"}}})
    specs = {s.name: s for s in load_robot(path).specs(str(tmp_path / "gen"))}
    assert [specs[n].stop_first for n in ("base", "enable", "laser")] == [True, False, False]


def test_transforms_string_and_mapping_forms_run_static_tf_nodes(tmp_path):
    path = write(tmp_path, {"transforms": {
        "cam": {"args": "0.1 0 0.35 0 pi/2 pi/2 base_link camera_link 100"},
        "laser": "0.2 0 0.3 0 0 0 base_link laser 100",
        "sonar": {"args": "0 0 0.2 0 0 0 base_link sonar", "respawn": True}}})
    specs = {s.name: s for s in load_robot(path).specs(str(tmp_path / "gen"))}
    assert all(s.module == "common.static_tf_node" for s in specs.values())
    assert specs["cam"].section == "transforms.cam"          # read from the user's file
    assert specs["sonar"].respawn
    gen = yaml.safe_load(Path(specs["laser"].config).read_text())
    assert gen["laser"] == {"args": "0.2 0 0.3 0 0 0 base_link laser 100"}
    assert gen["sonar"] == {"args": "0 0 0.2 0 0 0 base_link sonar"}


def test_simulator_overrides_go_to_a_generated_file(tmp_path):
    path = write(tmp_path, {"platform": {"sim": {"module": "robot_side.sim.node", "params": {"speed": 1.0}}}})
    launch = load_robot(path, world="room.yaml", start=[1.0, 2.0, 0.5], speed=5)
    (spec,) = launch.specs(str(tmp_path / "gen"))
    gen = yaml.safe_load(Path(spec.config).read_text())[spec.section]
    assert gen == {"speed": 5.0, "world": "room.yaml", "start": [1.0, 2.0, 0.5]}


def test_simulator_overrides_without_a_simulator_are_an_error(tmp_path):
    path = write(tmp_path, {"platform": {"p2os": {"module": "robot_side.p2os.node"}}})
    with pytest.raises(ConfigError) as e:
        load_robot(path, speed=2.0)
    assert "--speed" in str(e.value)


def test_disabled_nodes_are_skipped(tmp_path):
    path = write(tmp_path, {"sensors": {"a": {"module": "x"}, "b": {"module": "y", "enabled": False}}})
    assert [s.name for s in load_robot(path).specs(str(tmp_path / "gen"))] == ["a"]


@pytest.mark.parametrize("name", ["p3at_sim", "pioneer_lx_sim", "p3at_sim_virtual"])
def test_shipped_robot_configs_load(name):
    launch = load_robot(str(REPO / "robot_side/config" / f"{name}.yaml"))
    names = [e.name for e in launch.entries]
    assert names[0] == "sim"
    assert launch.entry("sim").stop_first
    assert launch.use_sim_time


def test_virtual_config_merger_waits_for_every_virtual_scan():
    launch = load_robot(str(REPO / "robot_side/config/p3at_sim_virtual.yaml"))
    merger = next(s for s in launch.specs() if s.name == "merger")
    topics = launch.entry("merger").params["laserscan_topics"]
    assert set(merger.wait_for) == set(topics)
    assert len(topics) == 8


def test_master_loader_reads_nodes_section_and_external_configs(tmp_path):
    (tmp_path / "mb.yaml").write_text("controller_frequency: 10.0\n")
    path = write(tmp_path, {"robot": "p1", "use_sim_time": True, "nodes": {
        "map_server": {"module": "master_side.mapping.map_server_node", "params": {"yaml": "m.yaml"}},
        "move_base": {"module": "master_side.planning.move_base_node", "config": "mb.yaml",
                      "respawn": True, "wait_for": "map odom", "after": ["map_server"]}}}, "m.yaml")
    launch = load_master(path)
    specs = {s.name: s for s in launch.specs(str(tmp_path / "gen"))}
    assert launch.robot == "p1"
    assert launch.use_sim_time
    assert specs["move_base"].config == str(tmp_path / "mb.yaml")
    assert specs["move_base"].wait_for == ("map", "odom")
    assert specs["move_base"].after == ("map_server",)


def test_master_loader_rejects_robot_sections(tmp_path):
    path = write(tmp_path, {"platform": {"b": {"module": "x"}}})
    with pytest.raises(ConfigError) as e:
        load_master(path)
    assert e.value.key == "platform"


def test_merge_included_takes_the_file_as_base_and_the_other_keys_as_overrides(tmp_path):
    from common.config import merge_included

    (tmp_path / "amcl.yaml").write_text("min_particles: 100\nmax_particles: 500\n")
    source = str(tmp_path / "master.yaml")
    cfg, src = merge_included({"amcl": "amcl.yaml", "max_particles": 900}, "amcl", source)
    assert cfg == {"min_particles": 100, "max_particles": 900}
    assert src == f"{tmp_path / 'amcl.yaml'} (+ overrides in {source})"
    assert merge_included({"max_particles": 900}, "amcl", source) == ({"max_particles": 900}, source)
    with pytest.raises(ConfigError, match="file not found"):
        merge_included({"amcl": "missing.yaml"}, "amcl", source)
