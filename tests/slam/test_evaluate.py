import math

import numpy as np
import pytest

from common.geometry import Pose2D
from master_side.slam.cli import main
from master_side.slam.evaluate import Relation, evaluate


def _path(n=20):
    t = np.arange(n) * 0.5 + 100.0
    poses = np.column_stack((np.cos(t / 3) * 4, np.sin(t / 3) * 3, np.mod(t / 3 + np.pi, 2 * np.pi) - np.pi))
    return t, poses


def _rel(t, poses, i, j, err=None):
    err = err if err is not None else Pose2D()
    return Relation(t[i], t[j], Pose2D(*poses[i]).between(Pose2D(*poses[j])).compose(err))


def test_perfect_trajectory_has_zero_error():
    t, p = _path()
    m = evaluate(t, p, [_rel(t, p, 0, 5), _rel(t, p, 3, 17), _rel(t, p, 9, 2)])
    assert m.trans.max() < 1e-12
    assert m.rot.max() < 1e-12


def test_a_known_constant_error_is_reported_exactly():
    t, p = _path()
    err = Pose2D(0.03, -0.04, math.radians(2.0))
    m = evaluate(t, p, [_rel(t, p, i, i + 4, err) for i in range(10)])
    s = m.summary()
    assert s["trans_mean_m"] == pytest.approx(0.05, abs=1e-9)
    assert s["trans_std_m"] == pytest.approx(0.0, abs=1e-9)
    assert s["rot_mean_deg"] == pytest.approx(2.0, abs=1e-9)
    assert s["relations"] == 10


def test_relations_without_a_pose_within_the_tolerance_are_skipped():
    t, p = _path()
    bad = Relation(t[0] + 0.01, t[3], Pose2D())
    m = evaluate(t, p, [_rel(t, p, 0, 3), bad])
    assert m.missing == 1
    assert len(m.trans) == 1


def test_eval_cli_prints_the_summary_line_last(tmp_path, capsys):
    t, p = _path()
    traj = tmp_path / "trajectory.txt"
    traj.write_text("".join(f"{a:.6f} {x:.6f} {y:.6f} {th:.6f}\n" for a, (x, y, th) in zip(t, p)))
    r = _rel(t, p, 1, 6, Pose2D(0.1, 0.0, 0.0))
    (tmp_path / "rel").write_text(f"{r.t1:.6f} {r.t2:.6f} {r.delta.x} {r.delta.y} 0 0 0 {r.delta.theta}\n")
    assert main(["eval", "--relations", str(tmp_path / "rel"), str(traj)]) == 0
    last = capsys.readouterr().out.strip().splitlines()[-1]
    assert last.startswith("trans_mean_m=0.1000 ")
    assert last.endswith("relations=1")
