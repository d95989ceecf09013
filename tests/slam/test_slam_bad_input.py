"""`zenav slam run` on a missing, truncated, binary or corrupt log: one line naming the file, exit 2."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def _slam_run(log: Path, out: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "deploy.cli", "slam", "run", str(log), "--out", str(out)],
                          capture_output=True, text=True, timeout=120, cwd=REPO)


def _check(r: subprocess.CompletedProcess, log: Path, words: str) -> None:
    assert r.returncode == 2, r.stdout + r.stderr
    assert "Traceback" not in r.stderr, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    assert str(log) in lines[0] and words in lines[0], lines[0]


def test_missing_log(tmp_path):
    _check(_slam_run(tmp_path / "missing.clf", tmp_path / "out"), tmp_path / "missing.clf", "no such file")


def test_carmen_log_with_a_cut_line_names_the_line(shared_dir, tmp_path):
    real = (shared_dir / "datasets" / "slam" / "intel.recon.clf").read_text().splitlines(keepends=True)
    scans = [i for i, line in enumerate(real) if line.startswith(("FLASER", "ROBOTLASER1"))]
    cut = scans[5]
    log = tmp_path / "cut.clf"
    log.write_text("".join(real[:cut]) + real[cut][: len(real[cut]) // 2] + "\n")
    _check(_slam_run(log, tmp_path / "out"), log, f":{cut + 1}: malformed")


@pytest.mark.parametrize("name", ["garbage.clf", "garbage.bag"])
def test_binary_garbage(tmp_path, name):
    log = tmp_path / name
    log.write_bytes(bytes(range(256)) * 64)
    r = _slam_run(log, tmp_path / "out")
    _check(r, log, "not a readable ROS1 bag" if name.endswith(".bag") else "not a CARMEN text log")


def test_truncated_bag(shared_dir, tmp_path):
    real = shared_dir / "datasets" / "slam" / "ros1_bags" / "intel.orig.bag"
    log = tmp_path / "truncated.bag"
    with open(real, "rb") as f:
        log.write_bytes(f.read(200_000))
    _check(_slam_run(log, tmp_path / "out"), log, "not a readable ROS1 bag")
