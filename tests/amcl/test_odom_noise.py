"""Odometry noise measured (master_side/localization/odom_noise.py, `zenav slam odom-noise`): the alphas of
odometry made with known ones come back, and the command reads a real log with a SLAM trajectory of it."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from common.geometry import Pose2D
from master_side.localization.motion_model import DiffMotionModel
from master_side.localization.odom_noise import fit

REPO = Path(__file__).resolve().parents[2]


def _drive(alphas: tuple[float, float, float, float], corrected: bool, n: int = 4000,
           seed: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """A reference path of n steps (0.1-0.4 m, turns up to 0.6 rad each way) and odometry whose every step
    is the reference's with the motion model's noise (the model's own sampler, one particle)."""
    rng = np.random.default_rng(seed)
    model = DiffMotionModel(*alphas, corrected=corrected)
    ref = [Pose2D(0.0, 0.0, 0.0)]
    odom = [np.zeros(3)]
    for _ in range(n):
        r1, t, r2 = rng.uniform(-0.6, 0.6), rng.uniform(0.1, 0.4), rng.uniform(-0.6, 0.6)
        a = ref[-1]
        b = Pose2D(a.x + t * math.cos(a.theta + r1), a.y + t * math.sin(a.theta + r1), a.theta + r1 + r2)
        # odometry sees the true step with noise: the model run backwards (truth = odometry's step + noise)
        step = model.sample(np.zeros((1, 3)), a, b, rng)[0]
        o = odom[-1]
        c, s = math.cos(o[2]), math.sin(o[2])
        odom.append(np.array([o[0] + c * step[0] - s * step[1], o[1] + s * step[0] + c * step[1], o[2] + step[2]]))
        ref.append(b)
    return np.array(odom), np.array([p.as_array() for p in ref])


@pytest.mark.parametrize("model", ["diff", "diff-corrected"])
def test_the_alphas_odometry_was_made_with_come_back(model):
    alphas = (0.05, 0.1, 0.08, 0.02) if model == "diff" else (0.01, 0.005, 0.004, 0.002)
    odom, ref = _drive(alphas, model == "diff-corrected")
    r = fit(odom, ref, model, min_d=0.05, min_a=0.05)  # every step a piece
    assert r.pieces == len(odom) - 1 and r.model == model
    got = (r.alpha1, r.alpha2, r.alpha3, r.alpha4)
    for k, (want, have) in enumerate(zip(alphas, got, strict=True), 1):
        assert have == pytest.approx(want, rel=0.15), (k, got)
    # noiseless odometry: every alpha tiny
    exact = fit(ref, ref, model, min_d=0.05, min_a=0.05)
    assert max(exact.alpha1, exact.alpha2, exact.alpha3, exact.alpha4) < 1e-6, exact


def test_odometry_that_barely_moves_or_does_not_match_the_reference_is_refused():
    still = np.zeros((50, 3))
    with pytest.raises(ValueError, match="moves too little"):
        fit(still, still)
    with pytest.raises(ValueError, match="same stamps"):
        fit(np.zeros((5, 3)), np.zeros((6, 3)))
    with pytest.raises(ValueError, match="diff or diff-corrected"):
        fit(np.zeros((5, 3)), np.zeros((5, 3)), "omni")


def test_zenav_slam_odom_noise_reads_the_intel_log_and_its_slam_trajectory(shared_dir, tmp_path):
    """The intel log's first 400 scans, SLAM's trajectory of them (zenav slam run), the alphas for amcl."""
    log = shared_dir / "datasets" / "slam" / "intel.recon.clf"
    cli = [sys.executable, "-m", "deploy.cli", "slam"]
    run = subprocess.run([*cli, "run", str(log), "--out", str(tmp_path), "--max-scans", "400",
                          "--config", "master_side/config/gmapping_datasets.yaml"],
                         capture_output=True, text=True, timeout=300, cwd=REPO)
    assert run.returncode == 0, run.stderr
    r = subprocess.run([*cli, "odom-noise", str(log), str(tmp_path / "trajectory.txt")],
                       capture_output=True, text=True, timeout=120, cwd=REPO)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.strip().splitlines()
    assert lines[0].startswith("# ") and "steps of 0.2 m" in lines[0] and lines[1] == "odom_model_type: diff"
    alphas = dict(line.split(": ") for line in lines[2:])
    assert sorted(alphas) == [f"odom_alpha{k}" for k in range(1, 5)]
    assert all(0.0 < float(v) < 100.0 for v in alphas.values()), alphas
    # a trajectory of some other log is refused, naming the mismatch
    other = tmp_path / "other.txt"
    other.write_text("".join(f"{1000.0 + k} 0 0 0\n" for k in range(50)))
    bad = subprocess.run([*cli, "odom-noise", str(log), str(other)], capture_output=True, text=True, timeout=120,
                         cwd=REPO)
    assert bad.returncode == 2 and "another log?" in bad.stderr, bad.stderr
