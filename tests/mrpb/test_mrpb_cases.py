"""MRPB's cases read from the dataset's own config.txt files (deploy/mrpb/cases.py)."""

from __future__ import annotations

import numpy as np
import pytest

from deploy.mrpb.cases import STATIC_ENVS, load_cases, parse_config, robot_map, world_map
from master_side.mapping.map_io import load_map


@pytest.fixture(scope="module")
def root(shared_dir):
    return shared_dir / "datasets" / "mrpb" / "map10cm"


def _cell(grid, x: float, y: float) -> int:
    c = int((x - grid.origin.x) / grid.resolution)
    r = int((y - grid.origin.y) / grid.resolution)
    return int(grid.data[r, c])


def test_every_static_environment_has_its_tests_and_each_start_is_free_in_the_world(root):
    cases = load_cases(root)
    assert {c.env for c in cases} == set(STATIC_ENVS)
    per_env = {e: [c.test for c in cases if c.env == e] for e in STATIC_ENVS}
    assert all(tests == list(range(1, len(tests) + 1)) for tests in per_env.values())
    assert len(per_env["track"]) == 1 and all(len(t) == 3 for e, t in per_env.items() if e != "track")
    for c in cases:  # a wrongly read pose would land in a wall or outside the map
        world = load_map(c.world_file)
        assert _cell(world, c.start[0], c.start[1]) == 0, c.name
        assert -np.pi - 0.01 <= c.start[2] <= np.pi + 0.01 and -np.pi - 0.01 <= c.goal[2] <= np.pi + 0.01


def test_a_partially_unknown_environment_runs_in_its_full_twin_which_holds_every_obstacle_of_its_map(root):
    for env in ("office02_partially_unknown", "shopping_mall_partially_unknown"):
        full, part = load_map(world_map(root, env)), load_map(robot_map(root, env))
        assert world_map(root, env).parent.name == env.removesuffix("_partially_unknown")
        occ_full, occ_part = full.data >= 65, part.data >= 65
        assert np.all(occ_full[occ_part])  # nothing the robot is told of is missing from the world
        assert occ_full.sum() > occ_part.sum()  # and the world has obstacles the map lacks
    assert world_map(root, "office02") == root.parent / "maps" / "office02" / "map.yaml"


def test_a_bad_config_is_refused_with_its_name(root, tmp_path):
    text = (root / "track" / "config.txt").read_text()
    assert len(parse_config(text)) == 1
    with pytest.raises(ValueError, match="broken.txt: an incomplete test"):
        parse_config(text.replace('name="goal_pose_a"', 'name="goal_pose_b"'), "broken.txt")
    with pytest.raises(ValueError, match="no test found"):
        parse_config("# nothing here", "empty.txt")
    with pytest.raises(FileNotFoundError, match="no such MRPB environment"):
        load_cases(root, ("atlantis",))
