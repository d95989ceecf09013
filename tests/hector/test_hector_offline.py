"""hector over the first scans of the aces log: odometry ignored, outputs as gmapping's runner."""

from __future__ import annotations

import itertools
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from common.geometry import Pose2D
from master_side.hector.offline import run
from master_side.hector.params import load_hector
from master_side.slam import cli
from master_side.slam.evaluate import evaluate, read_relations
from master_side.slam.logs import read_log

SCANS = 400
CONFIG = Path(__file__).resolve().parents[2] / "master_side" / "config" / "hector_datasets.yaml"


@pytest.fixture(scope="module")
def aces(shared_dir):
    log = shared_dir / "datasets" / "slam" / "aces.recon.clf"
    records = list(itertools.islice(read_log(log), SCANS))
    return log, records, read_relations(shared_dir / "datasets" / "slam" / "aces.relations")


def _relations_error(stamps, poses, relations) -> float:
    rel = [r for r in relations if stamps[0] <= min(r.t1, r.t2) and max(r.t1, r.t2) <= stamps[-1]]
    assert len(rel) >= 20
    return evaluate(stamps, poses, rel).summary()["trans_mean_m"]


def test_garbage_odometry_changes_nothing_and_the_trajectory_matches_ground_truth(aces):
    _, records, relations = aces
    params = load_hector(CONFIG)
    rng = np.random.default_rng(7)
    garbage = [replace(r, odom=Pose2D(*rng.uniform(-50, 50, 2), rng.uniform(-3, 3))) for r in records]
    good = run(None, params, records=records, progress=None)
    bad = run(None, params, records=garbage, progress=None)
    assert np.array_equal(good.poses, bad.poses)  # the odometry is never read
    # and the poses are right: Kümmerle relations over these scans (measured 0.046 m; the log's
    # odometry alone: 0.043 m on this straight start)
    assert _relations_error(bad.stamps, bad.poses, relations) < 0.08
    # the map holds the walls seen: a few thousand occupied cells
    grid = bad.slam.occupancy_grid(crop=True)
    assert 500 < int((grid.data == 100).sum()) < 20000


def test_cli_writes_map_and_trajectory_with_method_hector(aces, tmp_path, capfd):
    log, records, _ = aces
    out = tmp_path / "out"
    assert cli.main(["run", str(log), "--method", "hector", "--out", str(out), "--max-scans", "150",
                     "--set", "map_size=1024"]) == 0
    traj = np.loadtxt(out / "trajectory.txt")
    assert traj.shape == (150, 4)
    assert np.allclose(traj[:, 0], [r.stamp for r in records[:150]], atol=1e-5)
    assert (out / "map.pgm").stat().st_size > 1000 and "image: map.pgm" in (out / "map.yaml").read_text()
    assert "scans 150 map updates" in capfd.readouterr().err  # progress line


def test_cli_rejects_a_gmapping_only_parameter_with_method_hector(aces, tmp_path, capsys):
    log, _, _ = aces
    assert cli.main(["run", str(log), "--method", "hector", "--out", str(tmp_path), "--set", "particles=5"]) == 2
    assert "particles" in capsys.readouterr().err
