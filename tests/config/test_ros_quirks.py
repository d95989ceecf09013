"""ROS keys that are odd but real load as notes: a flat "namespace/key" and a key ROS reads only to warn."""

from __future__ import annotations

from common.config import Note
from master_side.planning.local import TrajectoryPlannerParams
from master_side.ros_params import BASE_LOCAL_PLANNER, load_ros_params


def test_flat_namespaced_key_and_a_misspelling_ros_only_warns_about_are_notes():
    notes: list[str] = []
    p = load_ros_params(TrajectoryPlannerParams, {"point_grid/max_sensor_range": 2.0, "acc_limit_x": 1.0,
                                                  "acc_lim_x": 2.0}, "lp.yaml", "TrajectoryPlannerROS",
                        BASE_LOCAL_PLANNER, notes)
    assert p.acc_lim_x == 2.0
    why = {n.key: n.why for n in notes if isinstance(n, Note)}
    assert "no effect" in why["TrajectoryPlannerROS.point_grid/max_sensor_range"]
    assert "acc_lim_x" in why["TrajectoryPlannerROS.acc_limit_x"]
