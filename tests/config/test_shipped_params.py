"""Every shipped master config and the reference tutorial's ROS files pass the agents' parameter check."""

from __future__ import annotations

from pathlib import Path

import pytest

from common.launch import Section, load_launch
from common.node_check import check_nodes
from master_side.costmap.params import check_costmap_node, load_costmap_files

REPO = Path(__file__).resolve().parents[2]
MASTER_CONFIGS = sorted((REPO / "master_side" / "config").glob("p3at_*.yaml"))


@pytest.mark.parametrize("path", MASTER_CONFIGS, ids=lambda p: p.stem)
def test_shipped_master_config_passes_the_check_with_nothing_to_report(path):
    launch = load_launch(path, [Section("nodes")])
    notes = check_nodes(launch)              # raises on any problem of any node
    mine = ("master_side.mapping.map_server_node", "master_side.localization.amcl_node", "master_side.slam.node")
    assert all(notes[e.name] == [] for e in launch.entries if e.opts.module in mine)
    costmaps = [e for e in launch.entries if e.opts.module == "master_side.costmap.node"]
    assert len(costmaps) == 2
    for e in costmaps:
        assert check_costmap_node(e.params, str(path.resolve())) == []


@pytest.mark.parametrize(("common", "specific", "expected"), [
    ("costmap_common_params.yaml", "global_costmap_params.yaml", set()),
    ("costmap_common_params.yaml", "local_costmap_params.yaml", set()),
    ("layered/costmap_common_params.yaml", "layered/global_costmap_params.yaml",
     {"static_map", "inflater.robot_radius"}),
])
def test_reference_tutorial_costmap_files_load_with_only_the_expected_notes(shared_dir, common, specific, expected):
    ref = shared_dir / "reference" / "p3at"
    notes: list[str] = []
    load_costmap_files(ref / common, ref / specific, notes=notes)
    assert {n.key for n in notes} == expected
