"""The BARN master config uses the challenge's files unchanged, and the agent's start-up check lists, in
one warning, every parameter in them that has no effect."""

from __future__ import annotations

from pathlib import Path

import pytest

from common.launch import load_launch
from common.node_check import check_nodes, format_notes
from master_side.agent import SECTIONS
from master_side.move_base.config import load_move_base_config

REPO = Path(__file__).resolve().parents[2]
CONFIG = REPO / "master_side" / "config" / "jackal_barn.yaml"


@pytest.mark.parametrize("name", ["base_local_planner_params.yaml", "costmap_common_params.yaml",
                                  "global_costmap_params.yaml", "local_costmap_params.yaml",
                                  "move_base_params.yaml", "move_base_DWA.launch"])
def test_barn_files_are_the_challenges_byte_for_byte(shared_dir, name):
    ours = REPO / "master_side" / "config" / "barn" / name
    theirs = shared_dir / "datasets" / "barn" / "ros_params" / name
    assert ours.read_bytes() == theirs.read_bytes()


def test_move_base_plans_and_controls_in_odom_with_the_rosparam_values():
    nodes = load_launch(str(CONFIG), SECTIONS)
    mb = next(e for e in nodes.entries if e.name == "move_base")
    c = load_move_base_config(mb.params, str(CONFIG))
    assert (c.global_frame, c.local_frame, c.base_frame) == ("odom", "odom", "base_link")
    assert c.params.planner_frequency == 20.0 and c.params.controller_frequency == 20.0
    assert c.local_kind == "base_local_planner/TrajectoryPlannerROS"
    p = c.local_params
    assert (p.dwa, p.meter_scoring, p.path_distance_bias, p.goal_distance_bias) == (True, True, 0.75, 1.0)
    assert (p.heading_scoring_timestep, p.simple_attractor, p.escape_vel) == (0.8, False, -0.5)
    # the footprint the planner checks is the file's, padded by footprint_padding (0.1) and nothing else
    assert sorted(map(tuple, c.footprint.round(3).tolist())) == [(-0.31, -0.265), (-0.31, 0.265), (0.31, -0.265),
                                                                  (0.31, 0.265)]


def test_one_startup_warning_lists_what_has_no_effect():
    notes = check_nodes(load_launch(str(CONFIG), SECTIONS))
    text = format_notes("master", notes)
    for key in ("meter_scoring", "publish_voxel_map", "shutdown_costmaps", "publish_cost_grid_pc", "static_map"):
        assert key in text, f"{key} missing from the start-up warning:\n{text}"
    assert text.count("warning") == 1
    assert set(notes) >= {"global_costmap", "local_costmap", "move_base"}
