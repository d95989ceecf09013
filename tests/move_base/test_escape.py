"""zenav's escape recovery on synthetic local costmaps: which move it plans, that its way is free for the
robot's own outline, and how move_base's recovery list builds it (driving the move: test_escape_recovery.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from common.config import ConfigError
from common.geometry import Pose2D
from master_side.costmap.cost_values import FREE, LETHAL, NO_INFORMATION
from master_side.move_base.escape import EscapeParams, plan_escape
from master_side.move_base.escape_recovery import EscapeRecovery
from master_side.move_base.params import MoveBaseParams
from master_side.move_base.recovery import recoveries_from_params
from tests.move_base.escape_grids import ORIGIN, P3AT, RES, FakeBase, grid_with, min_clearance


def test_a_wall_just_ahead_backs_the_robot_away_from_it():
    grid = grid_with((0.36, -2.0, 0.5, 2.0))  # a wall 3 cm beyond the nose
    move = plan_escape(grid, RES, ORIGIN, Pose2D(), P3AT)
    assert move is not None and move.turn == 0.0 and move.distance < 0.0
    # the shortest drive that leaves 0.15 m (within a cell of the grid's own rounding)
    assert 0.10 <= -move.distance <= 0.2
    assert move.clearance_after >= 0.15 - RES
    assert min_clearance(grid, Pose2D(move.distance, 0.0, 0.0)) >= 0.15 - 2 * RES


def test_walls_close_front_and_back_leave_no_move():
    # walls 5 cm beyond the nose and the rear: a drive nears one of them, a turn swings the corners into both
    grid = grid_with((0.38, -2.0, 0.6, 2.0), (-0.6, -2.0, -0.31, 2.0))
    why: list[str] = []
    assert plan_escape(grid, RES, ORIGIN, Pose2D(), P3AT, why=why) is None
    # the log says how close the walls are and what stopped the moves
    assert len(why) == 1 and why[0].startswith("clearance 0.0") and "by an obstacle" in why[0], why
    # with 0.4 m behind, backing away is the move
    move = plan_escape(grid_with((0.38, -2.0, 0.6, 2.0), (-0.9, -2.0, -0.65, 2.0)), RES, ORIGIN, Pose2D(), P3AT)
    assert move is not None and move.distance < 0


def test_forward_wins_over_the_same_drive_backwards():
    # a thin post beside the left flank's middle: as far either way leaves it behind; only sonars look behind
    grid = grid_with((-0.0125, 0.28, 0.0125, 0.3))
    params = EscapeParams(max_turn=0.0, max_distance=0.5)
    move = plan_escape(grid, RES, ORIGIN, Pose2D(), P3AT, params)
    assert move is not None and move.distance > 0.0
    back = plan_escape(grid, RES, ORIGIN, Pose2D(0.0, 0.0, math.pi), P3AT, params)  # the same, turned round
    assert back is not None and back.distance > 0.0 and back.distance == pytest.approx(move.distance)


def test_a_robot_in_the_open_does_not_move():
    why: list[str] = []
    assert plan_escape(grid_with(), RES, ORIGIN, Pose2D(), P3AT, why=why) is None
    assert why == ["free enough where it stands (clearance inf m)"]


def test_a_robot_boxed_in_says_every_move_is_blocked_and_by_what():
    # a wall 1.5 cm off the nose (a turn swings the front corners into it) and space no sensor has seen from
    # 1.5 cm behind the rear: no drive or turn is free
    grid = grid_with((0.345, -2.0, 0.6, 2.0))
    grid[:, : int((-0.27 - ORIGIN[0]) / RES)] = NO_INFORMATION
    logs: list[str] = []
    rec = EscapeRecovery(lambda: (grid, RES, ORIGIN, Pose2D()), P3AT, log=logs.append)
    rec.start(0.0)
    assert rec.move is None
    assert logs and logs[0].startswith("escape: no move gains clearance (clearance 0.0"), logs
    assert "every move is blocked (" in logs[0] and "by an obstacle" in logs[0] and "by unknown cells" in logs[0], logs


def test_the_way_must_be_free_all_along_not_only_at_its_end():
    # a wall 3 cm behind the rear and a thin post 0.1 m ahead of the nose: driving forward 0.3 m would end in
    # open space past the post's line only through it, so the escape may not drive through the post
    grid = grid_with((-0.6, -2.0, -0.285, 2.0), (0.43, -0.05, 0.46, 0.05))
    move = plan_escape(grid, RES, ORIGIN, Pose2D(), P3AT, EscapeParams(max_turn=0.0))
    assert move is None or move.distance <= 0.43 - 0.3302


def test_a_wall_beside_the_rear_corner_is_left_by_the_turn_that_swings_it_away():
    # a wall behind the left rear corner only (x < -0.1), 3 cm from the left side
    grid = grid_with((-2.0, 0.284, -0.1, 0.5))
    move = plan_escape(grid, RES, ORIGIN, Pose2D(), P3AT)
    assert move is not None
    if move.distance == 0.0:  # turning clockwise swings the left rear corner away from the wall
        assert move.turn < 0.0
    else:  # driving forward leaves it behind
        assert move.distance > 0.0


def test_after_a_stall_the_escape_moves_against_the_stalled_command_whatever_the_costmap_shows():
    """Stalled backing and turning left (v < 0, w > 0) in a costmap that shows nothing: a drive forward or a
    turn right, at least 0.1 m / 0.3 rad; a wall just ahead leaves the turn; nothing free against it: None."""
    from master_side.move_base.escape import STALL_BACKOFF

    assert plan_escape(grid_with(), RES, ORIGIN, Pose2D(), P3AT) is None  # nothing to escape from, it seems
    move = plan_escape(grid_with(), RES, ORIGIN, Pose2D(), P3AT, against=(-0.1, 0.3))
    assert move is not None
    assert (move.distance >= STALL_BACKOFF[0] - 1e-9) or (move.distance == 0 and move.turn <= -STALL_BACKOFF[1] + 1e-9)
    ahead = grid_with((0.36, -2.0, 0.5, 2.0))  # a wall 3 cm beyond the nose
    move = plan_escape(ahead, RES, ORIGIN, Pose2D(), P3AT, against=(-0.1, 0.3))
    assert move is not None and move.distance == 0.0 and move.turn < 0.0
    assert plan_escape(ahead, RES, ORIGIN, Pose2D(), P3AT, against=(-0.1, 0.0)) is None  # only forward would do


def test_the_recovery_list_builds_escapes_with_their_parameters_and_rejects_bad_ones():
    spec = [{"name": "reset", "type": "clear_costmap_recovery/ClearCostmapRecovery"},
            {"name": "escape", "type": "zenav/EscapeRecovery"}]
    params = MoveBaseParams(recovery_behaviors=spec)
    base = FakeBase(grid_with((0.36, -2.0, 0.5, 2.0)))
    stalls: list[tuple[float, float, float]] = []
    recs = recoveries_from_params(params, {"escape": {"max_distance": 0.2, "stall_time": 0.5}}, "mb.yaml",
                                  lambda *a: None, view=base.view, bare_footprint=P3AT, on_stall=stalls.append)
    assert [r.name for r in recs] == ["reset", "escape"]
    assert (recs[1].params.max_distance, recs[1].params.stall_time) == (0.2, 0.5)
    base.run(recs[1], held_after=0.0)  # held from the start: its stall reaches move_base's counter
    assert len(stalls) == 1
    with pytest.raises(ConfigError) as e:
        recoveries_from_params(params, {"escape": {"max_distance": 5.0}}, "mb.yaml", lambda *a: None)
    assert "mb.yaml" in str(e.value) and "max_distance" in str(e.value)


def test_a_bad_escape_parameter_fails_the_move_base_check_before_anything_starts():
    from master_side.move_base.config import check

    cfg = {"move_base": {"recovery_behaviors": [{"name": "esc", "type": "zenav/EscapeRecovery"}],
                         "esc": {"speed": 50.0}}}
    with pytest.raises(ConfigError) as e:
        check(cfg, "master.yaml")
    assert "esc" in str(e.value) and "speed" in str(e.value)
    cfg["move_base"]["esc"] = {"speed": 0.05}
    check(cfg, "master.yaml")  # in range: accepted


def test_a_corridor_as_narrow_as_the_robot_says_its_freest_move_gains_nothing():
    # walls 3 cm off each flank all along: drives are free but keep the 3 cm, turns meet the walls
    why: list[str] = []
    grid = grid_with((-2.0, 0.284, 2.0, 0.5), (-2.0, -0.5, 2.0, -0.284))
    assert plan_escape(grid, RES, ORIGIN, Pose2D(), P3AT, why=why) is None
    assert len(why) == 1 and why[0].startswith("clearance 0.03 m where it stands; the freest move, "), why
    assert "reaches 0.03 m" in why[0] and "moves blocked (16 by an obstacle)" in why[0], why
    # with turn_then_drive, every turn then drive (16 turns x 12 drives) meets a wall too
    why.clear()
    assert plan_escape(grid, RES, ORIGIN, Pose2D(), P3AT, EscapeParams(turn_then_drive=True), why=why) is None
    assert "moves blocked (208 by an obstacle)" in why[0], why


def slanted_wall(deg: float, off: float) -> np.ndarray:
    """A 10 cm wall beside the robot's left flank, ``off`` from its front left corner, closing in ahead at
    ``deg``: driving back gains clearance at sin(deg) of the distance."""
    t = math.radians(deg)
    xs = ORIGIN[0] + (np.arange(160) + 0.5) * RES
    x, y = np.meshgrid(xs, xs)
    d = (x - 0.254) * math.sin(t) + (y - (0.254 + off)) * math.cos(t)
    g = np.full((160, 160), FREE, np.uint8)
    g[(d >= 0) & (d <= 0.1)] = LETHAL
    return g


def test_a_gain_of_less_than_a_cell_is_taken_when_no_move_gains_a_whole_one():
    # as office02's robot stood: "clearance 0.07 m where it stands; the freest move, back 0.25 m, reaches 0.09 m"
    # on a 2.5 cm grid, while DWA rejected every trajectory; a drive of at most 5 cm gains 2.3 cm here
    grid = slanted_wall(20.0, 0.07)
    move = plan_escape(grid, RES, ORIGIN, Pose2D(), P3AT, EscapeParams(max_turn=0.0, max_distance=0.05))
    assert move is not None and move.distance == pytest.approx(-0.05)
    assert 0.0 < move.clearance_after - move.clearance_before < RES
    # with longer drives allowed a whole cell is gained, and that move wins
    longer = plan_escape(grid, RES, ORIGIN, Pose2D(), P3AT, EscapeParams(max_turn=0.0, max_distance=0.3))
    assert longer is not None and longer.clearance_after - longer.clearance_before >= RES


def test_no_gain_at_all_is_no_move():
    # the wall parallel to the flank, 5 cm off: a drive either way keeps the 5 cm
    why: list[str] = []
    grid = slanted_wall(0.0, 0.05)
    params = EscapeParams(max_turn=0.0, sidestep=False)
    assert plan_escape(grid, RES, ORIGIN, Pose2D(), P3AT, params, why=why) is None
    assert why and "reaches 0.05 m" in why[0], why


def test_beside_a_wall_along_the_flank_a_sidestep_gains_what_no_drive_or_turn_can():
    """office02's Kinect robot, 2026-12-02: 5 cm off a wall along its right flank, nothing ahead; a drive keeps
    the 5 cm, every turn swings a corner into the wall, DWA rejected every trajectory and three goals were
    aborted there. A forward sidestep (an arc away, the same arc back) leaves it parallel and farther off,
    its bare outline off the wall all the way."""
    from master_side.move_base.escape import _poses_along

    grid = grid_with((-2.0, -0.6, 2.0, -0.304))  # the wall 5 cm off the right flank, all along
    why: list[str] = []
    assert plan_escape(grid, RES, ORIGIN, Pose2D(), P3AT, EscapeParams(sidestep=False), why=why) is None
    assert "reaches 0.05 m" in why[0], why
    move = plan_escape(grid, RES, ORIGIN, Pose2D(), P3AT)
    assert move is not None and move.curvature > 0.0 and move.distance > 0.0 and move.turn == 0.0, move
    assert move.describe().startswith("sidestep left (forward "), move.describe()
    assert move.clearance_after >= move.clearance_before + RES
    way = _poses_along(Pose2D(), move.distance, 0.0, RES, 0.4, curvature=move.curvature)
    assert way[-1, 2] == pytest.approx(0.0, abs=1e-9) and way[-1, 1] > 0.02  # parallel again, to the left
    assert min(min_clearance(grid, Pose2D(*p)) for p in way[::3]) > 0.0
    assert min_clearance(grid, Pose2D(*way[-1])) >= move.clearance_before + RES - 1e-9
    # the wall on the left flank: the sidestep goes right; a wall ahead: backing away for room, as before
    mirrored = plan_escape(grid_with((-2.0, 0.304, 2.0, 0.6)), RES, ORIGIN, Pose2D(), P3AT)
    assert mirrored is not None and mirrored.curvature < 0.0 and mirrored.describe().startswith("sidestep right")
    ahead = plan_escape(grid_with((-2.0, -0.6, 2.0, -0.304), (0.6, -2.0, 0.8, 2.0)), RES, ORIGIN, Pose2D(), P3AT)
    assert ahead is not None and ahead.distance < 0.0 and not ahead.curvature and not ahead.turn, ahead


def test_an_escape_turn_sweeps_the_outline_about_the_bases_turning_centre():
    """A base that pivots 0.12 m behind base_link swings its front the other way round it: a turn free for a
    base turning about base_link may not be free for it, and the escape plans with where the base turns."""
    from master_side.move_base.escape import _poses_along

    pose = Pose2D(1.0, 2.0, 0.5)
    about_base = _poses_along(pose, 0.0, 1.0, 0.025, 0.4)
    np.testing.assert_allclose(about_base[:, :2], [[1.0, 2.0]] * len(about_base))
    cx = -0.12
    pivoted = _poses_along(pose, 0.0, 1.0, 0.025, 0.4, cx)
    pivot = np.array([1.0 + cx * np.cos(0.5), 2.0 + cx * np.sin(0.5)])
    np.testing.assert_allclose(np.hypot(*(pivoted[:, :2] - pivot).T), abs(cx), atol=1e-12)  # on the circle
    assert pivoted[-1, 2] == pytest.approx(about_base[-1, 2]) == pytest.approx(1.5)
    # base_link ends 0.12 m from the pivot, opposite the heading it turned to (1.5 rad), 0.115 m from the start
    np.testing.assert_allclose(pivoted[-1, :2], pivot - cx * np.array([np.cos(1.5), np.sin(1.5)]), atol=1e-12)
    assert np.hypot(*(pivoted[-1, :2] - [1.0, 2.0])) == pytest.approx(2 * 0.12 * np.sin(0.5), abs=1e-9)


def test_a_wall_ahead_with_no_clearance_to_gain_backs_the_robot_away_for_room():
    """A corridor's corner: a wall 0.3 m ahead of the nose, another 0.1 m beside the left flank all along. No
    single turn or drive gains clearance (a drive keeps the 0.1 m, a turn brings a corner nearer); DWA driving
    forward only (while mapping) cannot back away to make room to turn (office02, laser, 2026-11-30: every
    trajectory rejected, the goal aborted). Without turn_then_drive (the default) the longest free reverse
    drive that loses no clearance is taken; not without the wall ahead, and not with ``room_ahead`` 0."""
    beside = (-2.0, 0.354, 2.0, 0.6)
    grid = grid_with(beside, (0.63, -2.0, 0.9, 2.0))
    straight = EscapeParams(turn_then_drive=False)
    why: list[str] = []
    move = plan_escape(grid, RES, ORIGIN, Pose2D(), P3AT, straight, why=why)
    assert move is not None and move.turn == 0.0 and move.distance == pytest.approx(-0.3)
    assert move.clearance_after == pytest.approx(move.clearance_before)
    assert why and why[0].startswith("backing away: no move gains clearance and an obstacle lies 0.2"), why
    assert min_clearance(grid, Pose2D(-0.3, 0.0, 0.0)) >= move.clearance_before - RES
    # something 0.15 m behind the rear: the longest free drive back is shorter
    short = plan_escape(grid_with(beside, (0.63, -2.0, 0.9, 2.0), (-0.6, -2.0, -0.404, 2.0)), RES, ORIGIN,
                        Pose2D(), P3AT, straight)
    assert short is not None and -0.15 <= short.distance < 0.0
    # nothing ahead: no backing away; a sidestep, away from the wall (none without sidesteps)
    free_ahead = plan_escape(grid_with(beside), RES, ORIGIN, Pose2D(), P3AT, straight)
    assert free_ahead is not None and free_ahead.curvature < 0.0 and free_ahead.distance > 0.0, free_ahead
    no_side = EscapeParams(turn_then_drive=False, sidestep=False)
    assert plan_escape(grid_with(beside), RES, ORIGIN, Pose2D(), P3AT, no_side) is None
    assert plan_escape(grid, RES, ORIGIN, Pose2D(), P3AT, EscapeParams(room_ahead=0.0, turn_then_drive=False)) is None


def test_beside_a_wall_a_turn_then_a_drive_gains_the_clearance_no_single_move_can():
    """The same corner, as office02's laser robot stood for 500 s (2026-11-30, a wall ahead and one 5-8 cm off
    the flank; each straight backing kept the flank's clearance and DWA drove back in): turning the nose
    toward the flank's wall, then backing, moves the body away from that wall at a slant."""
    grid = grid_with((-2.0, 0.354, 2.0, 0.6), (0.63, -2.0, 0.9, 2.0))
    move = plan_escape(grid, RES, ORIGIN, Pose2D(), P3AT, EscapeParams(turn_then_drive=True))
    assert move is not None and move.turn > 0.0 and move.distance < 0.0, move  # nose to the wall, then back
    assert move.describe().startswith(f"turn +{math.degrees(move.turn):.0f} deg, then back"), move.describe()
    assert move.clearance_after >= EscapeParams().clearance - 1e-9 > move.clearance_before
    # the bare outline stays off the walls all along the way, and the end has the clearance (brute force)
    from master_side.move_base.escape import _poses_along

    way = _poses_along(Pose2D(), move.distance, move.turn, RES, 0.4)
    assert min(min_clearance(grid, Pose2D(*p)) for p in way[::4]) > 0.0
    assert min_clearance(grid, Pose2D(*way[-1])) >= EscapeParams().clearance - 2 * RES
    # the turn comes first, then the drive on the heading it ends at
    np.testing.assert_allclose(way[-1], [move.distance * math.cos(move.turn), move.distance * math.sin(move.turn),
                                         move.turn], atol=1e-9)


def test_the_office02_corner_where_the_laser_robot_stood_is_left_by_a_turn_then_a_drive(shared_dir):
    """MRPB's office02 as the local costmap would mark it (its walls, 2.5 cm cells) about the true pose where the
    laser robot stood from 400 s to 900 s of an exploration (2026-11-30): a wall 0.21 m ahead, another 0.08 m
    off the flank. The straight moves reproduce the run's log line ("back 0.30 m: clearance 0.08 -> 0.08 m");
    a turn then a drive gains clearance. The P3-AT pivots 0.12 m behind base_link (rotation_center_x)."""
    from master_side.mapping.map_io import load_map

    world = load_map(shared_dir / "datasets/mrpb/maps/office02/map.yaml")
    pose = Pose2D(-5.94, 5.62, 3.11)
    origin = (pose.x - 2.0, pose.y - 2.0)
    centres = origin[0] + (np.arange(160) + 0.5) * RES, origin[1] + (np.arange(160) + 0.5) * RES
    x, y = np.meshgrid(*centres)
    cols = ((x - world.origin.x) / world.resolution).astype(int)
    rows = ((y - world.origin.y) / world.resolution).astype(int)
    grid = np.where(world.data[rows, cols] >= 65, LETHAL, FREE).astype(np.uint8)
    straight = plan_escape(grid, RES, origin, pose, P3AT, EscapeParams(turn_then_drive=False), center_x=-0.12)
    assert straight is not None and straight.describe() == "back 0.30 m: clearance 0.08 -> 0.08 m"
    move = plan_escape(grid, RES, origin, pose, P3AT, EscapeParams(turn_then_drive=True), center_x=-0.12)
    assert move is not None and move.turn and move.distance, move
    assert move.clearance_after >= move.clearance_before + 0.03, move.describe()


def test_room_ahead_is_measured_from_the_outlines_own_front_row_by_row():
    """A post in front of the body's front left corner, beside the nose (x 0.254-0.330): 3 cm ahead of that
    corner, though behind the nose's tip; measured from the nose alone it was never seen."""
    from master_side.move_base.escape import room_ahead

    grid = grid_with((0.285, 0.15, 0.31, 0.2))
    assert room_ahead(grid, RES, ORIGIN, Pose2D(), P3AT, 0.5) == pytest.approx(0.03, abs=RES)
    assert room_ahead(grid_with(), RES, ORIGIN, Pose2D(), P3AT, 0.5) == 0.5  # nothing ahead


def test_a_flank_wall_nearer_toward_the_rear_still_lets_the_robot_back_away_for_room():
    """The corner as office02's Kinect robot stood in it (2026-12-01, three goals aborted there): the wall
    beside the left flank not parallel but 3 degrees nearer toward the rear, 0.1 m off the rear corner, a wall
    0.14 m beyond the nose. Backing brings the rear corner a cell nearer that wall on the grid (0.10 -> 0.075
    m): the backing away counts a loss within a cell as none and backs the whole 0.3 m (on the old code 0.1 m,
    where the corner had not yet lost its cell; where it had after 5 cm, in the run, no move at all)."""
    grid = grid_with((0.47, -2.0, 0.9, 2.0))
    rows, cols = np.indices(grid.shape)
    x, y = ORIGIN[0] + (cols + 0.5) * RES, ORIGIN[1] + (rows + 0.5) * RES
    grid[(y >= 0.36 + math.tan(math.radians(3.0)) * x) & (y < 0.6)] = LETHAL
    params = EscapeParams(turn_then_drive=False)
    why: list[str] = []
    move = plan_escape(grid, RES, ORIGIN, Pose2D(), P3AT, params, why=why)
    assert move is not None and move.turn == 0.0 and move.distance == pytest.approx(-0.3), (move, why)
    assert move.clearance_before > move.clearance_after >= move.clearance_before - RES - 1e-9
    assert why and why[0].startswith("backing away"), why
    # the way back is free for the bare outline all along
    assert min(min_clearance(grid, Pose2D(-d, 0.0, 0.0)) for d in np.arange(0.0, 0.31, 0.05)) > 0.05
