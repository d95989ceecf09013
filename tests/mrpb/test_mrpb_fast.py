"""One MRPB case in one process (deploy/mrpb/inproc.py), measured as bench/mrpb.py measures it.

office01add's test 3 leaves a room through a narrow corridor. With the local costmap padded by 0.04 m
(zenav's former P3-AT choice, 0.59 m wide) the robot did not get through: on MRPB's 0.1 m map DWA stood at
the corridor's mouth rejecting every trajectory while the global plan ran through it, on the 0.05 m map
(used here, deploy/mrpb/cases.py) it had not arrived after 300 s; with MRPB's own 0.01 m
(p3at_zenav/local_costmap_params.yaml) it passes."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from deploy.mrpb import metrics
from deploy.mrpb.cases import load_cases
from deploy.mrpb.inproc import run_case_fast
from master_side.mapping.map_io import load_map

REPO = Path(__file__).resolve().parents[2]
ROBOT = REPO / "robot_side" / "config" / "p3at_sim_laser.yaml"
MASTER = REPO / "master_side" / "config" / "p3at_zenav.yaml"


def test_p3at_zenav_leaves_office01add_through_its_narrow_corridor(shared_dir):
    case = load_cases(shared_dir / "datasets" / "mrpb" / "map10cm", ("office01add",), (3,))[0]
    r = run_case_fast(case, ROBOT, MASTER)
    assert r.status == "success", r.reason
    end = r.trace[-1]
    assert math.hypot(end[1] - case.goal[0], end[2] - case.goal[1]) <= 0.3 + 0.05  # the tutorial's tolerance
    m = metrics.compute(r.trace, metrics.DistanceField.of(load_map(case.world_file)), 0.46)
    straight = math.hypot(case.goal[0] - case.start[0], case.goal[1] - case.start[1])
    assert m.path_m > straight and m.time_s > m.path_m / 0.55  # no faster than DWA's max_vel_x
    # the centre never came nearer a wall cell's centre than half the robot (0.254 m) and half a cell
    assert m.d_min_m > 0.254 + 0.05
    assert all(np.isfinite([m.d_mean_m, m.danger_pct, m.accel_mean, m.jerk_mean, m.ang_accel_mean]))
