"""`zenav explore` refuses to start without SLAM, or with a bad parameter file, in one line, exit 2."""

from __future__ import annotations

import subprocess
import sys
import uuid
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def _explore(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "deploy.cli", "explore", "--robot", f"nobody{uuid.uuid4().hex[:6]}",
                           "--no-multicast", *args], capture_output=True, text=True, timeout=60, cwd=REPO)


def test_without_slam_explore_says_so_in_one_line_and_exits_2():
    r = _explore("--wait", "1", "--no-save")
    assert r.returncode == 2 and r.stdout == "", r
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "no map (is SLAM running?" in lines[0], r.stderr


def test_a_bad_parameter_file_is_refused_naming_the_key(tmp_path):
    p = tmp_path / "explore.yaml"
    p.write_text("progress_timout: 10\n")
    r = _explore("--params", str(p))
    assert r.returncode == 2 and f"{p}: progress_timout: unknown key; did you mean 'progress_timeout'" in r.stderr
