"""`zenav explore` as a user runs it (``zenav robot`` + ``zenav master`` with SLAM while navigating, the
master file bench/explore.py and ``zenav demo --explore`` use), in the room with the planar laser: it must
map the room by itself and stop, without a contact. This is what catches a configuration that wedges the
robot (a wall SLAM's map moves under it) or a search that ends at the first door."""

from __future__ import annotations

from pathlib import Path

import pytest

from common.geometry import Pose2D
from deploy.logs.mcap_io import read_records
from deploy.mrpb.exploration import run_exploration
from deploy.stack.map_check import WorldTruth
from master_side.slam import node as slam_node
from master_side.slam.evaluate import read_trajectory
from master_side.slam.logs import scan_records
from master_side.slam.offline import run as offline_run

ROOT = Path(__file__).resolve().parents[2]
MASTER = ROOT / "master_side/config/p3at_slam_zenav.yaml"


@pytest.mark.slow
def test_the_room_is_mapped_by_exploration_which_ends_by_itself_without_a_contact(tmp_path):
    lines: list[str] = []
    run = run_exploration("room_laser", "room", Pose2D(-2.2, 0.0, 0.0),
                          ROOT / "robot_side/config/p3at_sim_laser.yaml",
                          MASTER, tmp_path, speed=2.0,
                          time_limit_s=240.0, echo=lines.append, record=("scan", "odom", "tf_static"))
    said = "\n".join(lines[-15:]) + f"\nlogs: {run.log_dir}"
    assert run.end == "done", said
    assert run.final_share >= 0.95, said
    assert run.agreement >= 0.95, said
    assert run.collisions == 0, (run.contacts, said)
    # the run recorded as `zenav record` does, and mapped again offline from the file (bench/slam_replay.py)
    mcap = Path(run.log_dir) / "run.mcap"
    recs = list(scan_records(((r.topic, r.msg) for r in read_records(mcap)), str(mcap)))
    assert len(recs) > 50, said
    assert recs[0].laser.as_array() == pytest.approx([0.1, 0.0, 0.0], abs=1e-6)  # p3at_sim_laser.yaml's mount
    # the live SLAM's trajectory, saved for bench/slam_replay.py --live: the scans it mapped are recorded ones
    stamps, _ = read_trajectory(Path(run.log_dir) / "slam_trajectory.txt")
    recorded = {round(r.stamp, 4) for r in recs}
    assert len(stamps) > 50 and f"{len(stamps)} mapped" in run.slam, (run.slam, said)
    record_log = Path(run.log_dir) / "record.log"  # its last lines count what never reached it ("lost")
    tail = "\n".join(record_log.read_text().splitlines()[-4:]) if record_log.exists() else "(no record.log)"
    assert sum(round(float(t), 4) in recorded for t in stamps) >= 0.95 * len(stamps), f"{said}\n{tail}"
    res = offline_run(mcap, slam_node.master_params(str(MASTER)), progress=None, records=recs)
    grid = res.slam.occupancy_grid(float(res.stamps[-1]))
    truth = WorldTruth.of("room", Pose2D(-2.2, 0.0, 0.0), grid.resolution)
    assert min(truth.agreement(grid)) >= 0.95 and truth.explored(grid) >= 0.95, said
