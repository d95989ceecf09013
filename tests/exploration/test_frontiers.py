"""Frontier search (master_side/exploration/frontiers.py) on synthetic costmaps whose frontiers are known."""

from __future__ import annotations

import numpy as np
import pytest

from master_side.costmap.cost_values import FREE, INSCRIBED, LETHAL, NO_INFORMATION
from master_side.exploration.frontiers import (
    Grid,
    costmap_forbidden,
    grid_from_map,
    nearest_lethal_m,
    reachable,
    search,
)

RES = 0.1


def _room() -> np.ndarray:
    """20 x 30 cells at 0.1 m, origin (0, 0): unknown everywhere but a known room x in [0.5, 1.5),
    y in [0.5, 1.5) with walls around it, a door 4 cells wide on its east wall (x = 1.5, y in
    [0.8, 1.2)), and, behind the west wall, a second known pocket that no free path reaches."""
    g = np.full((20, 30), NO_INFORMATION, np.uint8)
    g[5:15, 5:15] = FREE
    g[4, 4:16] = g[15, 4:16] = LETHAL
    g[4:16, 4] = g[4:16, 15] = LETHAL
    g[8:12, 15] = FREE  # the door: 4 cells
    g[6:10, 1:3] = FREE  # a pocket beyond the west wall, cut off from the robot
    return g


def test_the_door_is_the_one_frontier_and_a_pocket_beyond_a_wall_is_not():
    grid = Grid(_room(), RES, (0.0, 0.0))
    fs = search(grid, (1.0, 1.0), min_frontier_size=0.0)
    assert len(fs) == 1
    f = fs[0]
    # the unknown cells touching the door's free cells (4-connected): the 4 east of it, x = 1.6..1.7
    assert f.size == 4 and f.size_m == pytest.approx(0.4)
    assert f.centroid == pytest.approx((1.65, 1.0))
    assert f.min_distance == pytest.approx(np.hypot(0.65, 0.05))
    assert f.cost == pytest.approx(3.0 * f.min_distance * RES - 0.4)  # explore_lite's, its launch file's scale


def test_bigger_frontiers_win_by_gain_and_nearer_ones_by_potential():
    g = np.full((40, 40), FREE, np.uint8)
    g[:, 35:] = NO_INFORMATION  # far east: a 40-cell edge at x = 3.5
    g[:3, :5] = NO_INFORMATION  # near the robot, south-west: a small pocket (edges of 5 and 3 cells, one shared)
    grid = Grid(g, RES, (0.0, 0.0))
    robot = (0.6, 0.6)
    default = search(grid, robot, min_frontier_size=0.0)
    assert [f.size for f in default] == [40, 7]  # gain_scale 1 per metre of frontier: the long edge first
    by_distance = search(grid, robot, potential_scale=10.0, gain_scale=0.1, min_frontier_size=0.0)
    assert [f.size for f in by_distance] == [7, 40]
    assert [f.size for f in search(grid, robot, min_frontier_size=1.0)] == [40]  # 0.7 m is too small


def test_a_robot_on_a_costly_cell_searches_from_the_nearest_free_one_and_outside_the_map_is_refused():
    g = np.full((10, 10), FREE, np.uint8)
    g[:, 8:] = NO_INFORMATION
    g[4:7, 2:5] = INSCRIBED  # the robot stands inside an inflated region
    grid = Grid(g, RES, (0.0, 0.0))
    assert reachable(grid, (0.35, 0.55)).sum() == 8 * 10 - 9
    assert search(grid, (0.35, 0.55), min_frontier_size=0.0)[0].size == 10
    with pytest.raises(ValueError, match="outside the costmap"):
        search(grid, (5.0, 5.0))


def test_a_map_with_nothing_unknown_next_to_free_space_has_no_frontier():
    g = np.full((10, 10), FREE, np.uint8)
    g[0, :] = g[-1, :] = LETHAL
    g[:, 0] = g[:, -1] = LETHAL
    assert search(Grid(g, RES, (0.0, 0.0)), (0.5, 0.5)) == []


def test_a_slam_map_becomes_costs_with_the_robots_radius_kept_off_the_walls():
    from master_side.exploration.frontiers import grid_from_map

    m = np.zeros((10, 10), np.int8)
    m[:, 5] = 100  # a wall at x in [0.5, 0.6)
    m[:, 8:] = -1
    g = grid_from_map(m, RES, (0.0, 0.0), inscribed_radius=0.25)
    assert (g.data[:, 5] == LETHAL).all() and (g.data[:, 8:] == NO_INFORMATION).all()
    assert (g.data[:, 3:5] == INSCRIBED).all() and (g.data[:, 6:8] == INSCRIBED).all()  # 0.1 and 0.2 m off
    assert (g.data[:, :3] == FREE).all()  # 0.3 m and more
    # a gap narrower than the robot leaves the unknown beyond it unreachable: no frontier
    assert search(g, (0.15, 0.5), min_frontier_size=0.0) == []



def test_the_goal_is_where_the_robot_can_stand_beside_the_frontier_not_its_centroid():
    """A known square (x, y in [0.5, 2.0)) with a crate in its middle, unknown all around: one ring-shaped
    frontier whose centroid (1.25, 1.25) lies on the crate, where move_base refuses a goal. The goal is the
    reachable cell nearest the frontier cell nearest the centroid: beside the frontier. The door of the
    room above gets the reachable cell in the doorway, not its centroid in unknown space."""
    g = np.full((30, 30), NO_INFORMATION, np.uint8)
    g[5:20, 5:20] = FREE
    g[10:15, 10:15] = LETHAL
    grid = Grid(g, RES, (0.0, 0.0))
    (f,) = search(grid, (0.7, 0.7), min_frontier_size=0.0)
    assert f.centroid == pytest.approx((1.25, 1.25))
    assert g[grid.cell(*f.centroid)] == LETHAL
    goal = grid.cell(*f.goal)
    assert reachable(grid, (0.7, 0.7))[goal]
    gap = np.hypot(f.cells[:, 0] - f.goal[0], f.cells[:, 1] - f.goal[1])
    assert gap.min() == pytest.approx(RES)  # beside the frontier
    assert np.hypot(f.goal[0] - 1.25, f.goal[1] - 1.25) == pytest.approx(0.7)  # beside its nearest cell

    (door,) = search(Grid(_room(), RES, (0.0, 0.0)), (1.0, 1.0), min_frontier_size=0.0)
    assert door.goal[0] == pytest.approx(1.55) and door.goal[1] in (pytest.approx(0.95), pytest.approx(1.05))


def test_the_band_along_walls_the_robot_cannot_enter_still_borders_frontiers():
    """A corridor 0.7 m wide (x in [0.5, 1.2)) running north into unknown space, its walls' inscribed bands
    (0.25 m each) leaving a 0.2 m strip the robot's centre can use: the frontier across its end is the whole
    width the robot sees from that strip (explore_lite's FREE-neighbour rule gives the strip's 2 cells, under
    min_frontier_size), and no frontier is seen through a wall."""
    g = np.full((40, 20), NO_INFORMATION, np.uint8)
    g[0:20, 5:12] = FREE
    g[0:20, 4] = g[0:20, 12] = LETHAL
    g[0:20, 5:8] = g[0:20, 9:12] = INSCRIBED  # the bands; the strip is column 8
    g[0:20, 14:17] = FREE  # known space beyond the east wall, not joined to the corridor
    grid = Grid(g, RES, (0.0, 0.0))
    fs = search(grid, (0.85, 0.5), min_frontier_size=0.5, inscribed_radius=0.25)
    assert len(fs) == 1, fs
    f = fs[0]
    assert f.size == 7 and set(np.round(f.cells[:, 1], 2)) == {2.05}  # the row just north of the corridor
    assert grid.cell(*f.goal) == (19, 8)  # on the strip, at the frontier


def test_the_goal_leaves_room_to_turn_in_place_when_such_a_cell_is_near():
    """A frontier along y = 2.0 (unknown north of it) with a pillar 0.1 m below its middle: the reachable cell
    nearest the middle is beside the pillar, where the P3-AT (circumscribed radius 0.36 m) cannot turn to face
    the frontier (move_base aborted such goals: "rotation to the goal yaw would collide"). With the radius
    given, the goal is the nearest cell clear by that radius, still within a metre of the frontier."""
    g = np.full((40, 40), NO_INFORMATION, np.uint8)
    g[0:20, :] = FREE
    g[17:19, 19:21] = LETHAL  # the pillar, x and y in [1.7, 1.9) x [1.9, 2.1)
    grid = Grid(g, RES, (0.0, 0.0))
    (tight,) = search(grid, (2.0, 0.5), min_frontier_size=0.0)
    (roomy,) = search(grid, (2.0, 0.5), min_frontier_size=0.0, circumscribed_radius=0.36)
    pillar = np.array([(x, y) for x in (1.95, 2.05) for y in (1.75, 1.85)])

    def clearance(p):
        return float(np.min(np.hypot(pillar[:, 0] - p[0], pillar[:, 1] - p[1])))

    assert clearance(tight.goal) < 0.36 and np.hypot(*np.subtract(tight.goal, tight.middle)) < 0.5
    assert clearance(roomy.goal) >= 0.36 + RES / 2
    assert np.min(np.hypot(roomy.cells[:, 0] - roomy.goal[0], roomy.cells[:, 1] - roomy.goal[1])) <= 1.0


def test_a_robot_in_a_pocket_of_free_cells_searches_from_the_free_space_beside_it_not_through_a_wall():
    """The mall: SLAM's map left the robot's cell in a 3-cell free pocket, cut off by inflated specks from the
    free space 0.1 m away; searched from the pocket, one frontier was seen and exploration ended at 19 %."""
    g = np.full((12, 12), FREE, np.uint8)
    g[:, 10:] = NO_INFORMATION
    g[4:9, 1:6] = INSCRIBED
    g[6, 3] = FREE  # the pocket the robot stands in
    grid = Grid(g, RES, (0.0, 0.0))
    robot = (0.35, 0.65)
    assert reachable(grid, robot).sum() == 1  # without a radius: the pocket alone
    assert reachable(grid, robot, seed_radius=0.3).sum() == 12 * 10 - 25 + 1
    assert search(grid, robot, min_frontier_size=0.0, inscribed_radius=0.3)[0].size == 12
    # behind a wall, free cells within the radius are not the robot's
    g2 = g.copy()
    g2[:, 6] = LETHAL
    g2[:, 7:10] = FREE
    grid2 = Grid(g2, RES, (0.0, 0.0))
    near = (0.55, 0.65)  # a cell of the inflated band next to the wall; free cells 0.2 m behind it
    assert not reachable(grid2, near, seed_radius=0.3)[:, 7:].any()


def test_goals_avoid_what_move_bases_global_costmap_forbids_and_its_obstacles_never_wall_the_robot_in():
    """The mall: a goal chosen on SLAM's map alone lay on an obstacle only the global costmap held; move_base
    refused it ("in an obstacle") and its frontier was blacklisted. The costmap's forbidden cells (coarser,
    another origin) move the goal off the obstacle; an obstacle across the door, though, only moves the goal:
    laid over the whole search, the costmap's obstacles walled the robot into a pocket (1 frontier of 48)."""
    room = _room()
    grid = Grid(room, RES, (0.0, 0.0))
    goal = search(grid, (1.0, 1.0), min_frontier_size=0.0)[0].goal
    cm = np.zeros((15, 20), np.uint8)  # 0.2 m cells from (-0.4, -0.4)
    cm[int((goal[1] + 0.4) // 0.2), int((goal[0] + 0.4) // 0.2)] = INSCRIBED
    cm[0, 0] = NO_INFORMATION  # unknown in the costmap forbids nothing
    no_goal = costmap_forbidden(grid, Grid(cm, 0.2, (-0.4, -0.4)))
    assert no_goal.shape == room.shape and no_goal[int(goal[1] / RES), int(goal[0] / RES)]
    assert no_goal.sum() == 4  # one 0.2 m cell is four 0.1 m ones
    moved = search(grid, (1.0, 1.0), min_frontier_size=0.0, no_goal=no_goal)[0].goal
    assert moved != goal and not no_goal[int(moved[1] / RES), int(moved[0] / RES)]
    door = np.zeros((15, 20), np.uint8)
    door[4:9, 9] = LETHAL  # x in [1.4, 1.6), y in [0.4, 1.4): the doorway and the cells before it
    blocked = costmap_forbidden(grid, Grid(door, 0.2, (-0.4, -0.4)))
    fs = search(grid, (1.0, 1.0), min_frontier_size=0.0, no_goal=blocked)
    assert len(fs) == 1 and not blocked[int(fs[0].goal[1] / RES), int(fs[0].goal[0] / RES)]
    everything = np.ones_like(room, bool)  # no cell left for a goal: the goals SLAM's map gives
    assert search(grid, (1.0, 1.0), min_frontier_size=0.0, no_goal=everything)[0].goal == goal
    with pytest.raises(ValueError, match="not the grid's shape"):
        search(grid, (1.0, 1.0), no_goal=np.zeros((3, 3), bool))


def test_a_robot_that_backed_off_the_known_map_still_searches_from_the_free_space_nearest_it():
    """The mall: the robot backed 0.3 m into space its forward laser had never seen, beyond the known part of
    SLAM's map the search keeps (cropped for speed); 'outside the costmap' every second, no goal, no motion,
    for good. The search now keeps the robot's cell and starts from the free cell nearest it."""
    slam = np.full((40, 40), -1, np.int8)  # OccupancyGrid values, 0.1 m cells
    slam[5:15, 5:15] = 0  # a known free patch, unknown all around
    robot = (1.85, 1.0)  # 0.35 m east of the patch: off its known part and the 2-cell margin
    grid = grid_from_map(slam, RES, (0.0, 0.0), inscribed_radius=0.0, keep=robot)
    assert grid.cell(*robot) is not None
    assert grid_from_map(slam, RES, (0.0, 0.0), inscribed_radius=0.0).cell(*robot) is None  # as it was
    fs = search(grid, robot, min_frontier_size=0.0, inscribed_radius=0.0)
    assert len(fs) == 1 and fs[0].size == 40  # the patch's whole border
    # the full (uncropped) grid gives the search the same answer
    full = Grid(np.where(slam < 0, NO_INFORMATION, FREE).astype(np.uint8), RES, (0.0, 0.0))
    assert search(full, robot, min_frontier_size=0.0, inscribed_radius=0.0)[0].size == 40


def test_a_robot_whose_free_region_is_a_small_pocket_searches_across_the_band_along_walls():
    """The mall, 71 %: the robot's free region (6.9 m^2) was parted from the rest of SLAM's map (689 m^2) by a
    band nearer a wall than the inscribed radius, with no wall across it; one frontier was seen from there.
    A pocket (under POCKET_SHARE of the known free area) is searched across that band; a LETHAL wall still
    parts, and a region that is not a small share is searched as it is."""
    g = np.full((40, 40), FREE, np.uint8)
    g[:, 35:] = NO_INFORMATION  # the frontier, far east
    g[0:6, 0:6] = FREE
    g[6:8, 0:8] = INSCRIBED  # the band: no wall, but nearer one than the robot's radius
    g[0:8, 6:8] = INSCRIBED
    pocket_robot = (0.25, 0.25)
    grid = Grid(g, RES, (0.0, 0.0))
    assert reachable(grid, pocket_robot).sum() == 36
    fs = search(grid, pocket_robot, min_frontier_size=0.0, inscribed_radius=0.0)
    assert fs and fs[0].centroid[0] > 3.4  # the east frontier, seen across the band
    assert all(grid.cell(*f.goal) is not None and g[grid.cell(*f.goal)] < INSCRIBED for f in fs)
    walled = g.copy()
    walled[6, 0:8] = walled[0:7, 6] = LETHAL  # a wall across the band: the pocket stays a pocket
    assert not search(Grid(walled, RES, (0.0, 0.0)), pocket_robot, min_frontier_size=0.0, inscribed_radius=0.0)
    big = g.copy()
    big[0:6, 0:6] = NO_INFORMATION
    big[0:30, 0:30] = FREE  # the robot's region is most of the known free area now ...
    big[30:32, 0:32] = INSCRIBED
    big[0:32, 30:32] = INSCRIBED  # ... and the band parts it from a strip with the east frontier
    fs_big = search(Grid(big, RES, (0.0, 0.0)), pocket_robot, min_frontier_size=0.0, inscribed_radius=0.0)
    assert not fs_big


def test_the_nearest_obstacle_says_whether_a_turn_in_place_is_free():
    """A wall cell 0.30-0.35 m east of the robot (0.05 m cells): 0.30 m to its edge, so a P3-AT's 0.36 m
    turning circle is not free; looked for within 0.25 m it is out of reach; none at all on an empty grid or
    off the grid."""
    data = np.full((40, 40), FREE, np.uint8)
    data[20, 26] = LETHAL  # x from 0.30 to 0.35 m
    grid = Grid(data, 0.05, (-1.0, -1.0))  # the robot at (0, 0): the corner of cells (20, 20) and (19, 19)
    assert nearest_lethal_m(grid, 0.0, 0.0, 0.36) == pytest.approx(np.hypot(0.325, 0.025) - 0.025, abs=1e-9)
    assert nearest_lethal_m(grid, 0.0, 0.0, 0.25) == float("inf")
    assert nearest_lethal_m(Grid(np.full((40, 40), FREE, np.uint8), 0.05, (-1.0, -1.0)), 0.0, 0.0, 0.36) == float("inf")
    assert nearest_lethal_m(grid, 10.0, 10.0, 0.36) == float("inf")
    assert nearest_lethal_m(grid, 0.32, 0.02, 0.36) == 0.0  # on it
