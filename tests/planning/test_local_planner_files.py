"""The local planners' parameter files: the tutorial's P3-AT files load unchanged, bad values are refused,
and a planner file may include another."""

from __future__ import annotations

import pytest

from common.config import ConfigError, load_params, read_yaml
from master_side.planning.local import DWAPlannerParams, TrajectoryPlannerParams


def test_p3at_files_load_unchanged(shared_dir):
    ref = shared_dir / "reference" / "p3at"
    dwa = load_params(
        DWAPlannerParams,
        read_yaml(ref / "dwa_planner_ros.yaml")["DWAPlannerROS"],
        source="dwa_planner_ros.yaml",
        section="DWAPlannerROS",
    )
    assert (dwa.min_vel_x, dwa.max_vel_x, dwa.acc_lim_th, dwa.xy_goal_tolerance) == (-0.55, 0.55, 2.0, 0.3)
    assert dwa.latch_xy_goal_tolerance
    assert not dwa.holonomic_robot
    tp = load_params(
        TrajectoryPlannerParams,
        read_yaml(ref / "base_local_planner_params.yaml")["TrajectoryPlannerROS"],
        source="base_local_planner_params.yaml",
        section="TrajectoryPlannerROS",
    )
    assert (tp.max_vel_x, tp.min_vel_x, tp.acc_lim_theta, tp.escape_vel) == (0.5, 0.1, 0.5, -0.1)
    assert tp.min_in_place_vel_theta == 0.5
    assert tp.max_vel_theta == 0.5


@pytest.mark.parametrize(
    ("cls", "data"),
    [
        (DWAPlannerParams, {"acc_lim_x": -1.0}),
        (DWAPlannerParams, {"min_vel_x": 0.6, "max_vel_x": 0.5}),
        (DWAPlannerParams, {"vx_samples": 0}),
        (DWAPlannerParams, {"sim_tim": 1.0}),
        (DWAPlannerParams, {"holonomic_robot": "no"}),
        (TrajectoryPlannerParams, {"escape_vel": 0.1}),
        (TrajectoryPlannerParams, {"min_vel_theta": 0.5}),
        (TrajectoryPlannerParams, {"sim_time": 0.0}),
    ],
)
def test_bad_values_raise_config_error(cls, data):
    with pytest.raises(ConfigError):
        load_params(cls, data, source="test.yaml", section="X")



def test_a_planner_file_may_take_another_as_its_base(tmp_path):
    """``include:`` in a local planner file's section (zenav): the other file's section, this one's keys
    over it; a missing file is a ConfigError naming the key."""
    from master_side.move_base.config import load_move_base_config

    (tmp_path / "base.yaml").write_text("DWAPlannerROS:\n  max_vel_x: 0.4\n  min_vel_x: -0.1\n")
    (tmp_path / "skid.yaml").write_text("DWAPlannerROS:\n  include: base.yaml\n  rotation_center_x: -0.12\n")
    cfg = {"move_base": {"base_local_planner": "dwa_local_planner/DWAPlannerROS"}, "local_planner": "skid.yaml"}
    p = load_move_base_config(cfg, str(tmp_path / "move_base.yaml")).local_params
    assert (p.max_vel_x, p.min_vel_x, p.rotation_center_x) == (0.4, -0.1, -0.12)
    (tmp_path / "skid.yaml").write_text("DWAPlannerROS:\n  include: nowhere.yaml\n")
    with pytest.raises(ConfigError, match="DWAPlannerROS.include"):
        load_move_base_config(cfg, str(tmp_path / "move_base.yaml"))
