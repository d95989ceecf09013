"""The public BARN benchmark's move_base parameter files load into zenav without any edit; the ROS
parameters without effect in zenav come back as notes naming the file, the key and why."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from common.config import Note
from master_side.costmap.params import load_costmap_files
from master_side.ros_params import BASE_LOCAL_PLANNER, COMPONENTS, MOVE_BASE, load_ros_params


@pytest.fixture(scope="module")
def barn(shared_dir) -> Path:
    return shared_dir / "datasets" / "barn" / "ros_params"


def _by_key(notes: list[str]) -> dict[str, str]:
    return {n.key.split(".")[-1]: n.why for n in notes if isinstance(n, Note)}


@pytest.mark.parametrize("which", ["global", "local"])
def test_barn_costmap_files_load_unchanged_and_list_what_has_no_effect(barn, which):
    notes: list[str] = []
    cfg = load_costmap_files(barn / "costmap_common_params.yaml", barn / f"{which}_costmap_params.yaml",
                             notes=notes)
    assert cfg.name == f"{which}_costmap"
    assert cfg.style == "layered"
    assert [(x.name, x.type) for x in cfg.layers] == [("obstacles_layer", "costmap_2d::ObstacleLayer"),
                                                      ("inflater_layer", "costmap_2d::InflationLayer")]
    scan = dict(cfg.layers[0].sources)["scan"]
    assert (scan.topic, scan.sensor_frame, scan.data_type) == ("front/scan", "front_laser", "LaserScan")
    assert cfg.layers[1].params.inflation_radius == pytest.approx(0.30)
    # the costmap-level ranges reach the obstacle layer, as Costmap2DROS copies them there
    assert (cfg.layers[0].params.obstacle_range, cfg.layers[0].params.raytrace_range) == (2.5, 3.0)
    why = _by_key(notes)
    assert why["meter_scoring"] == "no effect here (a base_local_planner parameter)"
    for voxel_key in ("publish_voxel_map", "z_voxels", "z_resolution", "origin_z"):
        assert "VoxelLayer" in why[voxel_key] and why[voxel_key].startswith("no effect")
    assert "pre-Hydro" in why["static_map"] and "pre-Hydro" in why["map_type"]
    assert set(why) == set(cfg.ignored)
    by_file = {n.key: n.source for n in notes}
    assert by_file["meter_scoring"].endswith("costmap_common_params.yaml")
    assert by_file[f"{which}_costmap.static_map"].endswith(f"{which}_costmap_params.yaml")
    assert all(str(n).startswith(f"{n.source}: {n.key}: no effect") for n in notes)


def test_every_key_of_the_barn_planner_and_move_base_files_is_a_ros_parameter_of_that_node(barn):
    blp = yaml.safe_load((barn / "base_local_planner_params.yaml").read_text())["TrajectoryPlannerROS"]
    mb = yaml.safe_load((barn / "move_base_params.yaml").read_text())
    assert set(blp) - COMPONENTS[BASE_LOCAL_PLANNER] == set()
    assert set(mb) - COMPONENTS[MOVE_BASE] == set()


def test_barn_trajectory_planner_section_loads_with_the_zenav_planner_params(barn):
    from master_side.planning.local.trajectory_planner import TrajectoryPlannerParams

    src = str(barn / "base_local_planner_params.yaml")
    section = yaml.safe_load(Path(src).read_text())["TrajectoryPlannerROS"]
    notes: list[str] = []
    p = load_ros_params(TrajectoryPlannerParams, section, src, "TrajectoryPlannerROS", BASE_LOCAL_PLANNER, notes)
    assert p.max_vel_x == 0.5
    why = _by_key(notes)
    # every key the planner does not read is reported, none silently dropped
    from master_side.ros_params import accepted_names

    assert set(section) - accepted_names(TrajectoryPlannerParams) <= set(why) <= set(section)
    assert all(w.startswith("no effect") for w in why.values())
