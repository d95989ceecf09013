"""Issue 7 acceptance, online: the simulated robot maps the room with SLAM while it navigates a loop
(across the crate, to the far corner, back to the start), and the map's walls lie within two cells
of the true walls.

Runs the demo machinery (robot agent + master agent with slam_gmapping on the tutorial's
gmapping.yaml, costmaps and move_base, on a private loopback bus) and compares the latched SLAM map
with the simulator's world (``deploy.stack.map_check``).
"""

from __future__ import annotations

import pytest

from tests.slam_e2e.slam_demo import run_slam_demo, wall_length

# fraction of occupied map cells within two cells of a true wall. room: the acceptance
# (measured 99.8-100 %; 60 % before the matcher's motion prior). corridor: mapped "decently" (measured
# 93-100 % over recorded drives and filter seeds; 67 % before).
WITHIN_TWO_CELLS = {"room": 0.95, "corridor": 0.85}
CELL = 0.05  # gmapping's delta (the tutorial's file keeps the default)
# real time, as the hector test: the filter keeps ROS's queue of 5 scans, so a node starved of CPU drops
# scans and the update after a stall integrates all the robot's motion of the stall at once. At 2x, on a
# loaded CI machine, one run mapped 93.2 % (p95 0.115 m): twice the motion per stall, for the same CPU.
# Three runs side by side with two CPU hogs at 2x dropped 291-395 of 765-881 scans and still mapped 100 %,
# so a stall, not the drops, is the inferred cause; the demo now prints the node's scan counters.
SPEED = 1.0



@pytest.mark.slow
# the corridor (bound 85 %, measured 93-100 %) is left out of the suite for time:
# `zenav demo --slam --world corridor` runs it; WITHIN_TWO_CELLS keeps its bound
@pytest.mark.parametrize("world", ["room"])
def test_slam_e2e_map_of_a_loop_has_its_walls_within_two_cells(world, robot_name, tmp_path):
    ok, results, acc = run_slam_demo(world, True, robot_name, tmp_path, speed=SPEED)
    goals = [f"{r.name}: {r.reason}" for r in results]
    # the room loop is the acceptance; in the corridor a navigation failure (move_base's business,
    # seen once in ~5 runs) still leaves a map worth checking, so only the map is asserted there
    if world == "room":
        assert ok, f"the loop was not driven: {goals} (logs in {tmp_path})"
    assert acc is not None, f"no SLAM map received (logs in {tmp_path})"
    print(f"{world}: {acc}")
    # the loop sees most of the walls: a map of a few lucky cells must not pass
    assert acc.occupied_cells * CELL >= 0.5 * wall_length(world), acc
    assert acc.within_two_cells >= WITHIN_TWO_CELLS[world], f"{acc} (map: {tmp_path / f'slam_{world}.pgm'})"
