"""Laser noise measured (master_side/localization/laser_noise.py, `zenav slam laser-noise`): the fit gives
back the deviation of distances drawn with a known one, follows the range noise of scans cast in a map, and
the command reads a real log with SLAM's trajectory and map of it."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from common.geometry import Pose2D
from master_side.localization.laser_noise import end_point_distances, fit
from master_side.localization.likelihood_field import LikelihoodField
from tests.amcl.amcl_support import box_map, cast_scan

REPO = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize(("sigma", "share"), [(0.03, 0.99), (0.08, 0.9), (0.2, 0.7)])
def test_the_fit_gives_back_a_known_deviation_and_share(sigma, share):
    rng = np.random.default_rng(7)
    n = 50_000
    hits = np.abs(rng.normal(0.0, sigma, int(n * share)))
    rand = rng.uniform(0.0, 2.0, n - len(hits))
    r = fit(np.concatenate((hits, rand)), 2.0)
    assert r.sigma_hit == pytest.approx(sigma, rel=0.05)
    assert r.hit_share == pytest.approx(share, abs=0.02)
    assert r.yaml() == f"laser_sigma_hit: {r.sigma_hit:.4g}"


def test_noisier_ranges_give_a_larger_deviation():
    grid = box_map()
    field = LikelihoodField(grid, 2.0)
    rng = np.random.default_rng(3)
    poses = np.column_stack((rng.uniform(-3.0, 3.0, 60), rng.uniform(-2.5, 2.5, 60), rng.uniform(-3, 3, 60)))
    poses = poses[field.distance_at(poses[:, :2]) > 0.3]  # in free space
    got = {}
    for noise in (0.01, 0.1):
        scans = []
        for p in poses:
            s = cast_scan(grid, Pose2D(*p), np.pi, 181, 0.1, 8.0, noise=noise, rng=rng)
            scans.append((np.asarray(s.ranges), s.angles()))
        got[noise] = fit(end_point_distances(field, poses, scans, Pose2D(), 0.1, 8.0), 2.0).sigma_hit
    # the map's cells (0.05 m) set a floor; 0.1 m of range noise shows, less along walls met at an angle
    assert got[0.01] < 0.045
    assert 0.05 < got[0.1] < 0.12
    assert got[0.1] > 1.5 * got[0.01]


def test_too_few_points_and_no_points_near_obstacles_are_refused():
    with pytest.raises(ValueError, match="at least 10"):
        fit(np.zeros(3), 2.0)
    with pytest.raises(ValueError, match="max_dist"):
        fit(np.zeros(20), 0.0)


def test_zenav_slam_laser_noise_reads_the_aces_log_with_its_slam_map(shared_dir, tmp_path):
    """The aces log's first 300 scans, SLAM's map and trajectory of them (zenav slam run), σ for amcl."""
    log = shared_dir / "datasets" / "slam" / "aces.recon.clf"
    cli = [sys.executable, "-m", "deploy.cli", "slam"]
    run = subprocess.run([*cli, "run", str(log), "--out", str(tmp_path), "--max-scans", "300",
                          "--config", "master_side/config/gmapping_datasets.yaml"],
                         capture_output=True, text=True, timeout=300, cwd=REPO)
    assert run.returncode == 0, run.stderr
    r = subprocess.run([*cli, "laser-noise", str(log), str(tmp_path / "trajectory.txt")],
                       capture_output=True, text=True, timeout=120, cwd=REPO)
    assert r.returncode == 0, r.stderr
    head, line = r.stdout.strip().splitlines()
    assert head.startswith("# ") and "beam end points of 300 scans" in head
    key, value = line.split(": ")
    assert key == "laser_sigma_hit" and 0.01 < float(value) < 0.2, r.stdout  # SLAM's own map: cells' size
    missing = subprocess.run([*cli, "laser-noise", str(log), str(tmp_path / "trajectory.txt"), "--map",
                              str(tmp_path / "none.yaml")], capture_output=True, text=True, timeout=120, cwd=REPO)
    assert missing.returncode == 2 and "cannot read the map" in missing.stderr, missing.stderr
