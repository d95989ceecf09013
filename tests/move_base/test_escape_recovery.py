"""EscapeRecovery driving the move plan_escape planned: both legs of a turn then a drive, a move held by a
wall no sensor shows (a stall), something appearing in its way, no costmap."""

from __future__ import annotations

import math

import pytest

from common.geometry import Pose2D
from master_side.move_base.escape import EscapeParams, plan_escape
from master_side.move_base.escape_recovery import EscapeRecovery
from tests.move_base.escape_grids import ORIGIN, P3AT, RES, FakeBase, grid_with, min_clearance


def test_the_recovery_drives_the_planned_move_and_stops():
    base = FakeBase(grid_with((0.36, -2.0, 0.5, 2.0)))
    logged: list[str] = []
    rec = EscapeRecovery(base.view, P3AT, log=logged.append)
    base.run(rec)
    assert rec.move is not None and rec.move.distance < 0
    assert base.pose.x == pytest.approx(rec.move.distance, abs=0.011)  # within one tick at 0.1 m/s
    assert "back" in logged[0] and "clearance" in logged[0]


def test_the_recovery_turns_then_drives_and_ends_where_the_plan_said():
    base = FakeBase(grid_with((-2.0, 0.354, 2.0, 0.6), (0.63, -2.0, 0.9, 2.0)))  # the corridor's corner
    logged: list[str] = []
    rec = EscapeRecovery(base.view, P3AT, EscapeParams(turn_then_drive=True), log=logged.append)
    rec.start(0.0)
    m = rec.move
    assert m is not None and m.turn and m.distance and ", then back" in logged[0], logged
    cmds = []
    for i in range(1, 400):
        (v, _, w), done = rec.step(i * 0.1, base.pose, (0.0, 0.0, 0.0))
        if done:
            break
        cmds.append((v, w))
        base.pose = base.pose.compose(Pose2D(v * 0.1, 0.0, w * 0.1))
    kinds = [("turn" if w else "drive") for v, w in cmds]
    assert kinds == sorted(kinds, reverse=True) and kinds[0] == "turn" and kinds[-1] == "drive"  # turn, then drive
    assert all(v == 0.0 for v, w in cmds if w) and all(v < 0.0 and w == 0.0 for v, w in cmds if v)
    # where the plan said, within a tick of each leg (0.04 rad, 0.01 m)
    assert base.pose.theta == pytest.approx(m.turn, abs=0.041)
    end = (m.distance * math.cos(m.turn), m.distance * math.sin(m.turn))
    assert math.hypot(base.pose.x - end[0], base.pose.y - end[1]) < 0.015
    assert min_clearance(base.grid, base.pose) >= m.clearance_after - 2 * RES


def test_a_move_held_by_something_unseen_ends_and_is_reported_as_a_stall():
    base = FakeBase(grid_with((0.36, -2.0, 0.5, 2.0)))  # a wall beyond the nose: the escape backs away
    logged: list[str] = []
    stalls: list[tuple[float, float, float]] = []
    rec = EscapeRecovery(base.view, P3AT, log=logged.append, on_stall=stalls.append)
    ticks = base.run(rec, held_after=0.03)  # a wall no sensor shows stops it 3 cm back
    assert rec.move is not None and rec.move.distance <= -0.1
    assert stalls == [(-rec.params.speed, 0.0, 0.0)]  # the command that got it nowhere, for the stall marks
    assert "stalled after 0.0" in logged[-1] and "something no sensor shows holds the robot" in logged[-1], logged
    assert ticks * 0.1 <= rec.params.stall_time + 0.6  # it ends within its stall time of the last progress
    # a move that is not held makes no stall
    free = FakeBase(grid_with((0.36, -2.0, 0.5, 2.0)))
    stalls.clear()
    free.run(EscapeRecovery(free.view, P3AT, on_stall=stalls.append))
    assert stalls == []


def test_a_move_that_stalled_is_not_planned_again_from_where_it_stalled():
    """The escape backs, something unseen holds it; started again where it stands, it does not back again (the
    same drive would stall the same way: 47 times at one place on office02); moved off, it may."""
    base = FakeBase(grid_with((0.36, -2.0, 0.5, 2.0)))  # a wall beyond the nose: the escape backs away
    logged: list[str] = []
    rec = EscapeRecovery(base.view, P3AT, log=logged.append)
    base.run(rec, held_after=0.01)
    assert rec.move is not None and rec.move.distance < 0 and "stalled after" in logged[-1]
    held_at = base.pose
    rec.start(1.0)
    assert rec.move is None or rec.move.distance >= 0, logged[-1]
    assert "stalled here before" in logged[-1], logged[-1]
    base.pose = held_at.compose(Pose2D(0.0, 0.0, 0.3))  # turned off the place where it stalled
    rec.start(2.0)
    assert rec.move is not None and rec.move.distance < 0, logged[-1]


def test_the_recovery_stops_when_something_appears_in_its_way():
    base = FakeBase(grid_with((0.36, -2.0, 0.5, 2.0)))
    rec = EscapeRecovery(base.view, P3AT)
    rec.start(0.0)
    assert rec.move is not None and rec.move.distance < 0
    base.grid = grid_with((0.36, -2.0, 0.5, 2.0), (-0.6, -2.0, -0.27, 2.0))  # a sonar hears a wall behind
    cmd, done = rec.step(0.1, base.pose, (0.0, 0.0, 0.0))
    assert done and cmd == (0.0, 0.0, 0.0)


def test_no_costmap_means_no_move():
    rec = EscapeRecovery(lambda: None, P3AT)
    rec.start(0.0)
    assert rec.step(0.0, Pose2D(), (0.0, 0.0, 0.0)) == ((0.0, 0.0, 0.0), True)


def test_a_robot_touching_a_wall_moves_off_it_not_along_or_into_it():
    """A wall's cells under the rear half of the left flank (a touch): a move that leaves them is planned and
    driven. Flat against a wall all along the flank, every turn swings a corner into it and every drive
    slides along it (new wall cells under the outline): no move."""
    grid = grid_with((-2.0, 0.25, -0.05, 0.5))  # from 4 mm inside the left flank outwards, behind x = -0.05
    move = plan_escape(grid, RES, ORIGIN, Pose2D(), P3AT)
    assert move is not None and move.clearance_before == 0.0
    assert move.turn > 0.0 or move.distance > 0.0  # counter-clockwise swings the rear corner off; forward leaves it
    base = FakeBase(grid)
    base.run(EscapeRecovery(base.view, P3AT))
    assert min_clearance(grid, base.pose) > min_clearance(grid, Pose2D()) + RES
    assert plan_escape(grid_with((-2.0, 0.25, 2.0, 0.5)), RES, ORIGIN, Pose2D(), P3AT) is None


def test_the_recovery_drives_a_sidestep_arc_by_arc_and_ends_parallel_beside_where_it_stood():
    base = FakeBase(grid_with((-2.0, -0.6, 2.0, -0.304)))  # a wall 5 cm off the right flank, all along
    logged: list[str] = []
    rec = EscapeRecovery(base.view, P3AT, log=logged.append)
    rec.start(0.0)
    m = rec.move
    assert m is not None and m.curvature > 0.0 and logged[0].startswith("escape: sidestep left"), logged
    turns = []
    for i in range(1, 400):
        (v, _, w), done = rec.step(i * 0.1, base.pose, (0.0, 0.0, 0.0))
        if done:
            break
        assert v > 0.0
        turns.append(w)
        base.pose = base.pose.compose(Pose2D(v * 0.1, 0.0, w * 0.1))
    else:
        raise AssertionError("the sidestep never ended")
    assert turns[0] > 0.0 and turns[-1] < 0.0  # to the left, then back
    assert abs(base.pose.theta) < 0.06  # parallel again, within a tick's turn
    assert base.pose.y > 0.02 and base.pose.x == pytest.approx(m.distance, abs=0.05)
    assert min_clearance(base.grid, base.pose) >= m.clearance_before + RES - 0.01


def test_a_sidestep_that_stalled_is_not_planned_again_from_where_it_stalled():
    base = FakeBase(grid_with((-2.0, -0.6, 2.0, -0.304)))
    logged: list[str] = []
    rec = EscapeRecovery(base.view, P3AT, log=logged.append)
    base.run(rec, held_after=0.03)  # something unseen holds the robot 3 cm into the first arc
    assert any("stalled after" in line for line in logged), logged
    rec.start(10.0)  # from where it stalled: no sidestep to that side again, and none to the wall's side
    assert rec.move is None or not rec.move.curvature > 0.0, rec.move
