"""Issue 13 acceptance, online: `zenav demo --slam hector` — the simulated P3-AT with its planar laser
(robot_side/config/p3at_sim_laser.yaml) maps the room with hector_mapping (the scan alone, no
odometry) while it drives the room's loop, and the map's walls lie within two cells of the true walls.

The demo machinery as the gmapping test (test_slam_e2e_room.py): robot agent + master agent with
hector_mapping on hector_p3at.yaml, costmaps and move_base, on a private loopback bus; the latched map
is compared with the simulator's world (``deploy.stack.map_check``).
"""

from __future__ import annotations

import pytest

from tests.slam_e2e.slam_demo import run_slam_demo, wall_length

# fraction of occupied map cells within two cells of a true wall: the bound (measured 100 % in
# the room and the corridor; 78-83 % with the Kinect's 57-degree scan, the robot 1-2 m off by then)
WITHIN_TWO_CELLS = 0.95
CELL = 0.05  # hector_p3at.yaml's map_resolution
# real time, not the other SLAM tests' 2x: without odometry every scan has to be matched before the next
# moves the robot too far; at 2x with a CPU hog beside the suite the node fell behind and lost track once
# (50 % of the cells within two cells, a doubled room)
SPEED = 1.0



@pytest.mark.slow
def test_hector_demo_maps_the_room_with_its_walls_within_two_cells(robot_name, tmp_path):
    # the corridor (measured 100 %) is left out for the suite's time: `zenav demo --slam hector`
    ok, results, acc = run_slam_demo("room", "hector", robot_name, tmp_path, speed=SPEED)
    goals = [f"{r.name}: {r.reason} ({r.xy_error:.2f} m)" for r in results]
    assert ok, f"the loop was not driven: {goals} (logs in {tmp_path})"
    assert acc is not None, f"no SLAM map received (logs in {tmp_path})"
    print(f"room: {acc}")
    # the laser sees most of the walls: a map of a few lucky cells must not pass
    assert acc.occupied_cells * CELL >= 0.5 * wall_length("room"), acc
    assert acc.within_two_cells >= WITHIN_TWO_CELLS, f"{acc} (map: {tmp_path / 'slam_room.pgm'})"
