"""`zenav explore` as a user runs it (``zenav robot`` + ``zenav master`` with SLAM while navigating, the
master file bench/explore.py and ``zenav demo --explore`` use), in the room with the planar laser: it must
map the room by itself and stop, without a contact. This is what catches a configuration that wedges the
robot (a wall SLAM's map moves under it) or a search that ends at the first door."""

from __future__ import annotations

from pathlib import Path

import pytest

from common.geometry import Pose2D
from deploy.mrpb.exploration import run_exploration

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_the_room_is_mapped_by_exploration_which_ends_by_itself_without_a_contact(tmp_path):
    lines: list[str] = []
    run = run_exploration("room_laser", "room", Pose2D(-2.2, 0.0, 0.0),
                          ROOT / "robot_side/config/p3at_sim_laser.yaml",
                          ROOT / "master_side/config/p3at_slam_zenav.yaml", tmp_path, speed=2.0,
                          time_limit_s=240.0, echo=lines.append)
    said = "\n".join(lines[-15:]) + f"\nlogs: {run.log_dir}"
    assert run.end == "done", said
    assert run.final_share >= 0.95, said
    assert run.agreement >= 0.95, said
    assert run.collisions == 0, (run.contacts, said)
