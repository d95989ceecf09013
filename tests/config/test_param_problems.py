"""All problems of a parameter mapping in one error, with a did-you-mean; ROS keys without effect as notes."""

from __future__ import annotations

from dataclasses import dataclass

import pytest
import yaml

from common.config import ConfigError, Note, Problems, load_params, param
from master_side.costmap.params import load_costmap_config
from master_side.ros_params import (
    BASE_LOCAL_PLANNER,
    DWA_LOCAL_PLANNER,
    NAVFN,
    load_ros_params,
    no_effect_keys,
    owners,
)


@dataclass(frozen=True)
class Toy:
    inflation_radius: float = param(0.5, lo=0.0, hi=5.0, unit="m")
    cost_scaling_factor: float = param(10.0, lo=0.0)
    publish_voxel_map: bool = param(False, no_effect=True, doc="accepted; not published")


BARN_COMMON = """
map_type: costmap
obstacle_range: 2.5
raytrace_range: 3.0
footprint: [[-0.21, -0.165], [-0.21, 0.165], [0.21, 0.165], [0.21, -0.165]]
footprint_padding: 0.1
plugins:
- {name: obstacles_layer, type: "costmap_2d::ObstacleLayer"}
- {name: inflater_layer, type: "costmap_2d::InflationLayer"}
obstacles_layer:
  observation_sources: scan
  scan: {sensor_frame: front_laser, data_type: LaserScan, topic: front/scan, marking: true, clearing: true}
inflater_layer:
  inflation_radius: 0.30
"""
LOCAL = {"local_costmap": {"global_frame": "odom", "rolling_window": True, "width": 10.0, "height": 10.0,
                           "resolution": 0.05}}


def test_every_problem_of_a_mapping_is_in_one_error_one_per_line():
    with pytest.raises(ConfigError) as e:
        load_params(Toy, {"inflation_radus": 1.0, "cost_scaling_factor": -1, "publish_voxel_map": 3},
                    source="f.yaml", section="inflater")
    err = e.value
    assert [(s, k) for s, k, _ in err.problems] == [("f.yaml", "inflater.inflation_radus"),
                                                    ("f.yaml", "inflater.cost_scaling_factor"),
                                                    ("f.yaml", "inflater.publish_voxel_map")]
    assert (err.source, err.key) == ("f.yaml", "inflater.inflation_radus")
    lines = str(err).splitlines()
    assert lines[0] == "f.yaml: inflater.inflation_radus: unknown key; did you mean 'inflation_radius'?"
    assert lines[1].startswith("f.yaml: inflater.cost_scaling_factor: -1.0 is out of range")
    assert lines[2] == "f.yaml: inflater.publish_voxel_map: expected true or false, got 3"


def test_single_problem_keeps_the_file_key_why_format():
    e = ConfigError("a.yaml", "k", "bad")
    assert str(e) == "a.yaml: k: bad"
    assert e.problems == [("a.yaml", "k", "bad")]


def test_problems_collects_errors_of_several_loads():
    problems = Problems()
    with problems.collect():
        load_params(Toy, {"inflation_radius": 9.0}, source="a.yaml")
    with problems.collect():
        load_params(Toy, {"cost_scalling_factor": 1.0}, source="b.yaml")
    with pytest.raises(ConfigError) as e:
        problems.raise_if_any()
    assert [(s, k) for s, k, _ in e.value.problems] == [("a.yaml", "inflation_radius"),
                                                        ("b.yaml", "cost_scalling_factor")]


def test_no_effect_keys_and_flagged_fields_become_notes_not_errors():
    notes: list[str] = []
    p = load_params(Toy, {"inflation_radius": 1.0, "publish_voxel_map": True, "meter_scoring": True},
                    source="c.yaml", no_effect={"meter_scoring": "no effect here (a base_local_planner parameter)"},
                    notes=notes)
    assert p.inflation_radius == 1.0 and p.publish_voxel_map is True
    assert notes == ["c.yaml: publish_voxel_map: no effect (not published)",
                     "c.yaml: meter_scoring: no effect here (a base_local_planner parameter)"]
    assert isinstance(notes[0], Note) and notes[1].key == "meter_scoring"


def test_costmap_files_with_two_typos_and_an_out_of_range_value_give_one_error_naming_all_three():
    common = yaml.safe_load(BARN_COMMON)
    common["footprint_paddng"] = 0.1                               # typo 1, common file
    common["inflater_layer"]["inflation_radus"] = 0.3              # typo 2, in a layer
    local = {"local_costmap": {**LOCAL["local_costmap"], "resolution": -0.05}}   # out of range, other file
    with pytest.raises(ConfigError) as e:
        load_costmap_config(common, local, ("common.yaml", "local.yaml"))
    got = {(s, k): why for s, k, why in e.value.problems}
    assert set(got) == {("common.yaml", "footprint_paddng"), ("common.yaml", "inflater_layer.inflation_radus"),
                        ("local.yaml", "local_costmap.resolution")}
    assert "did you mean 'footprint_padding'" in got[("common.yaml", "footprint_paddng")]
    assert "did you mean 'inflation_radius'" in got[("common.yaml", "inflater_layer.inflation_radus")]
    assert "out of range" in got[("local.yaml", "local_costmap.resolution")]
    assert len(str(e.value).splitlines()) == 3


def test_a_bad_costmap_level_range_is_reported_once_not_again_for_each_layer_and_source():
    common = yaml.safe_load(BARN_COMMON)
    common["obstacle_range"] = -1.0     # copied into the obstacle layer and inherited by its source
    with pytest.raises(ConfigError) as e:
        load_costmap_config(common, LOCAL, ("common.yaml", "local.yaml"))
    assert [(s, k) for s, k, _ in e.value.problems] == [("common.yaml", "obstacle_range")]


def test_a_key_of_another_ros_component_is_a_note_and_a_key_of_none_is_an_error():
    common = yaml.safe_load(BARN_COMMON) | {"meter_scoring": True, "controller_frequency": 5.0}
    notes: list[str] = []
    cfg = load_costmap_config(common, LOCAL, ("common.yaml", "local.yaml"), notes=notes)
    why = {n.key: n.why for n in notes}
    assert why["meter_scoring"] == "no effect here (a base_local_planner parameter)"
    assert why["controller_frequency"].startswith("no effect here (a move_base / base_local_planner")
    assert {"meter_scoring", "controller_frequency"} <= set(cfg.ignored)
    with pytest.raises(ConfigError, match="common.yaml: meter_scorring: unknown key; did you mean 'meter_scoring'"):
        load_costmap_config(common | {"meter_scorring": True}, LOCAL, ("common.yaml", "local.yaml"))


def test_layered_costmap_level_value_overrides_the_layer_as_in_ros_and_says_so():
    common = yaml.safe_load(BARN_COMMON) | {"inflation_radius": 0.5}
    notes: list[str] = []
    cfg = load_costmap_config(common, LOCAL, ("common.yaml", "local.yaml"), notes=notes)
    assert cfg.layers[1].params.inflation_radius == 0.5
    assert any(n.key == "inflater_layer.inflation_radius" and "overrides" in n.why for n in notes)


def test_catalogue_reasons_distinguish_unimplemented_deprecated_and_foreign_keys():
    @dataclass(frozen=True)
    class Planner:
        pdist_scale: float = param(0.6)
        max_vel_x: float = param(0.5)

    why = no_effect_keys(BASE_LOCAL_PLANNER, Planner)
    assert why["simple_attractor"] == "no effect (not implemented in zenav)"
    assert "'pdist_scale'" in why["path_distance_bias"]           # the current name; zenav reads the old one
    assert why["twirling_scale"] == "no effect here (a dwa_local_planner parameter)"
    assert "max_vel_x" not in why and "pdist_scale" not in why
    assert set(owners("sim_time")) == {BASE_LOCAL_PLANNER, DWA_LOCAL_PLANNER}
    with pytest.raises(ConfigError, match=r"NavfnROS.allow_unknwn: unknown key; did you mean 'allow_unknown'"):
        load_ros_params(Planner, {"allow_unknwn": True}, "n.yaml", "NavfnROS", NAVFN)
