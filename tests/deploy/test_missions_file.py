"""Mission files of `zenav goal --waypoints` (deploy/stack/missions.py): read as written, or refused naming
the file, the waypoint and the key; the command refuses a mission before it looks for move_base."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from common.config import ConfigError
from deploy.stack.missions import Waypoint, load_mission

REPO = Path(__file__).resolve().parents[2]


def _file(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "mission.yaml"
    p.write_text(text)
    return p


def test_waypoints_in_order_with_the_file_frame_as_default(tmp_path):
    p = _file(tmp_path, "frame: odom\nwaypoints:\n  - {x: 2.0, y: 1.4, yaw: 1.57, name: door}\n"
                        "  - {x: -2.2, y: 0}\n  - {x: 1, y: 2, yaw: 3, frame: map}\n")
    assert load_mission(p) == [Waypoint(2.0, 1.4, 1.57, "odom", "door"), Waypoint(-2.2, 0.0, 0.0, "odom", ""),
                               Waypoint(1.0, 2.0, 3.0, "map", "")]
    assert load_mission(_file(tmp_path, "waypoints: [{x: 1, y: 2}]"))[0].frame == "map"


@pytest.mark.parametrize(("text", "where", "why"), [
    ("waypoints:\n  - {x: 1}\n", "waypoints[0]", "missing y"),
    ("waypoints:\n  - {x: 1, y: 2}\n  - {x: 1, y: 2, yw: 3}\n", "waypoints[1].yw", "did you mean 'yaw'"),
    ("waypoints:\n  - {x: one, y: 2}\n", "waypoints[0].x", "expected a number"),
    ("waypoints:\n  - 3\n", "waypoints[0]", "expected a mapping"),
    ("waypoints: []\n", "waypoints", "no waypoint given"),
    ("waypoint:\n  - {x: 1, y: 2}\n", "waypoint", "did you mean 'waypoints'"),
    ("- {x: 1, y: 2}\n", "<file>", "top level must be a mapping"),
])
def test_a_bad_mission_is_refused_naming_the_file_the_waypoint_and_the_key(tmp_path, text, where, why):
    p = _file(tmp_path, text)
    with pytest.raises(ConfigError) as e:
        load_mission(p)
    assert f"{p}: {where}" in str(e.value) and why in str(e.value)


def test_zenav_goal_refuses_a_bad_mission_with_exit_2_and_one_line(tmp_path):
    p = _file(tmp_path, "waypoints:\n  - {x: 1}\n")
    r = subprocess.run([sys.executable, "-m", "deploy.cli", "goal", "--waypoints", str(p), "--no-multicast"],
                       capture_output=True, text=True, timeout=60, cwd=REPO)
    assert r.returncode == 2 and r.stderr.strip() == f"zenav goal: {p}: waypoints[0]: missing y", r.stderr
    r = subprocess.run([sys.executable, "-m", "deploy.cli", "goal", "1", "2", "3", "--loop"],
                       capture_output=True, text=True, timeout=60, cwd=REPO)
    assert r.returncode == 2 and "--loop and --stop-on-failure go with --waypoints" in r.stderr
