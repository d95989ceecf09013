from pathlib import Path

import pytest
import yaml

from common.config import ConfigError
from common.messages import Header
from master_side.costmap.layered import LayeredCostmap
from master_side.costmap.params import load_costmap_config, load_costmap_files

FIX = Path(__file__).parent / "fixtures"


def _yaml(rel: str) -> dict:
    return yaml.safe_load((FIX / rel).read_text())


def test_tutorial_global_costmap_loads_as_500_by_500_at_0_1():
    cfg = load_costmap_files(FIX / "costmap_common_params.yaml", FIX / "global_costmap_params.yaml")
    lc = LayeredCostmap.from_config(cfg)
    assert cfg.name == "global_costmap"
    assert cfg.style == "flat"
    assert lc.master.data.shape == (500, 500)
    assert lc.master.resolution == 0.1
    assert (lc.master.origin_x, lc.master.origin_y) == (-25.0, -25.0)
    assert cfg.costmap.global_frame == "map"  # leading '/' stripped
    assert [(x.name, x.type) for x in cfg.layers] == [("obstacle_layer", "costmap_2d::ObstacleLayer"),
                                                      ("inflation_layer", "costmap_2d::InflationLayer")]
    src = dict(cfg.layers[0].sources)["laser_scan_sensor"]
    assert (src.topic, src.data_type) == ("scan", "LaserScan")
    assert (src.obstacle_range, src.raytrace_range) == (5.0, 6.0)
    assert cfg.layers[1].params.cost_scaling_factor == 100.0
    assert lc.inscribed_radius == pytest.approx(0.254)  # footprint wins over robot_radius; padding 0


def test_tutorial_local_costmap_loads_as_120_by_120_at_0_025_rolling_in_odom():
    cfg = load_costmap_files(FIX / "costmap_common_params.yaml", FIX / "local_costmap_params.yaml")
    lc = LayeredCostmap.from_config(cfg)
    assert cfg.name == "local_costmap"
    assert lc.master.data.shape == (120, 120)
    assert lc.master.resolution == 0.025
    assert lc.rolling_window
    assert cfg.costmap.global_frame == "odom"


def test_tutorial_layered_files_give_voxel_and_inflation_layers():
    cfg = load_costmap_files(FIX / "layered/costmap_common_params.yaml",
                             FIX / "layered/global_costmap_params.yaml")
    lc = LayeredCostmap.from_config(cfg)
    assert cfg.style == "layered"
    assert lc.master.data.shape == (500, 500)
    assert [type(x).__name__ for x in lc.layers] == ["VoxelLayer", "InflationLayer"]
    vox = lc.layer("obstacles")
    assert (vox.params.z_voxels, vox.params.z_resolution) == (8, 0.25)
    src = vox.buffers["pointcloud_sensor"].params
    assert (src.data_type, src.min_obstacle_height, src.topic) == ("PointCloud2", 0.2, "camera/depth/points")
    assert lc.layer("inflater").params.inflation_radius == 0.35
    assert "static_map" in cfg.ignored


def test_flat_style_with_static_map_and_voxel_map_type_implies_those_layers():
    common = _yaml("costmap_common_params.yaml") | {"map_type": "voxel", "z_voxels": 12}
    spec = _yaml("global_costmap_params.yaml")
    spec["global_costmap"]["static_map"] = True
    cfg = load_costmap_config(common, spec, ("common.yaml", "global.yaml"))
    assert [x.type for x in cfg.layers] == ["costmap_2d::StaticLayer", "costmap_2d::VoxelLayer",
                                            "costmap_2d::InflationLayer"]
    assert cfg.layers[1].params.z_voxels == 12


def test_nav2_style_plugin_names_are_accepted():
    spec = {"plugins": ["obstacle_layer", "inflation_layer"], "resolution": 0.05,
            "obstacle_layer": {"plugin": "nav2_costmap_2d::ObstacleLayer", "observation_sources": "scan",
                               "scan": {"topic": "/scan", "data_type": "LaserScan",
                                        "obstacle_max_range": 2.0}},
            "inflation_layer": {"plugin": "nav2_costmap_2d::InflationLayer", "inflation_radius": 0.4}}
    cfg = load_costmap_config({}, spec, "nav2.yaml", name="local_costmap")
    assert dict(cfg.layers[0].sources)["scan"].obstacle_range == 2.0


@pytest.mark.parametrize(("where", "key", "value", "file", "shown"), [
    ("specific", "resolution", -0.1, "local.yaml", "local_costmap.resolution"),
    ("specific", "resoluton", 0.1, "local.yaml", "local_costmap.resoluton"),
    ("common", "inflation_radius", "big", "common.yaml", "inflation_radius"),
    ("common", "map_type", "octomap", "common.yaml", "map_type"),
    ("common", "footprint", [[0, 0], [1, 1]], "common.yaml", "footprint"),
    ("specific", "unseen_cost", 253, "local.yaml", "local_costmap.unseen_cost"),  # would refuse unseen cells
])
def test_bad_config_values_give_config_error_naming_file_and_key(where, key, value, file, shown):
    common, spec = _yaml("costmap_common_params.yaml"), _yaml("local_costmap_params.yaml")
    (spec["local_costmap"] if where == "specific" else common)[key] = value
    with pytest.raises(ConfigError) as e:
        load_costmap_config(common, spec, ("common.yaml", "local.yaml"))
    assert e.value.source == file
    assert e.value.key == shown


def test_bad_observation_source_value_names_the_source_key():
    common = _yaml("costmap_common_params.yaml")
    common["laser_scan_sensor"]["data_type"] = "Sonar"
    with pytest.raises(ConfigError, match="common.yaml: laser_scan_sensor.data_type"):
        load_costmap_config(common, _yaml("local_costmap_params.yaml"), ("common.yaml", "local.yaml"))


def test_bad_layer_value_in_layered_style_names_the_layer_key():
    common = _yaml("layered/costmap_common_params.yaml")
    common["obstacles"]["z_voxels"] = 40
    spec = _yaml("layered/global_costmap_params.yaml")
    with pytest.raises(ConfigError, match="common.yaml: obstacles.z_voxels"):
        load_costmap_config(common, spec, ("common.yaml", "global.yaml"))


def test_unknown_plugin_type_is_rejected():
    spec = _yaml("layered/global_costmap_params.yaml")
    spec["plugins"].append({"name": "sonar", "type": "range_sensor_layer::RangeSensorLayer"})
    with pytest.raises(ConfigError, match=r"plugins\[2\].type"):
        load_costmap_config(_yaml("layered/costmap_common_params.yaml"), spec, ("c.yaml", "g.yaml"))


def test_known_ros_keys_are_accepted_even_if_unused():
    spec = _yaml("local_costmap_params.yaml")
    spec["local_costmap"].update({"always_send_full_costmap": True, "track_unknown_space": True})
    cfg = load_costmap_config(_yaml("costmap_common_params.yaml"), spec, ("c.yaml", "l.yaml"))
    assert cfg.costmap.track_unknown_space


def test_unseen_cost_without_tracked_unknown_space_is_refused_and_with_it_unseen_cells_go_out_at_that_cost():
    common, spec = _yaml("costmap_common_params.yaml"), _yaml("local_costmap_params.yaml")
    spec["local_costmap"]["unseen_cost"] = 250
    with pytest.raises(ConfigError, match="unseen_cost needs track_unknown_space: true"):
        load_costmap_config(common, spec, ("common.yaml", "local.yaml"))
    spec["local_costmap"]["track_unknown_space"] = True
    cfg = load_costmap_config(common, spec, ("common.yaml", "local.yaml"))
    lcm = LayeredCostmap.from_config(cfg)
    lcm.master.data[:] = 255
    lcm.master.data[0, :3] = (0, 100, 254)
    msg = lcm.master.to_message(Header(0.0, "odom"), unknown_as=cfg.costmap.unseen_cost)
    assert list(msg.data[0, :4]) == [0, 100, 254, 250] and (msg.data[1:] == 250).all()
    assert (lcm.master.data[1:] == 255).all()  # the costmap itself still knows what is unseen
    assert (lcm.master.to_message(Header(0.0, "odom")).data[1:] == 255).all()  # ROS's way by default
