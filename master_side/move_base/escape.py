"""An escape recovery (zenav's; nav2's BackUp and DriveOnHeading are its nearest relatives): when the local
planner finds no move because the padded footprint touches walls on every trajectory, move the robot by
one short straight drive (forward or back), one in-place turn, (``turn_then_drive``, off by default) a
short turn followed by a drive, or, when none of those gains clearance, a forward sidestep (an arc away
and the same arc back: parallel again, beside where it stood), to the nearby pose where its outline is
farthest from obstacles, checking the robot's bare outline (no padding) along the whole way.

ROS 1's move_base has no recovery that moves the robot out of a tight spot: rotate_recovery ends at once
when a turn would touch an obstacle, and the costmap resets do not move it. In a narrow doorway, beside
a wall it has just been told about by a sonar or a bumper, a robot then stands until its goal is aborted.

Pure: ``plan_escape`` takes the local costmap's grid and the robot's pose in its frame and plans the move;
``escape_recovery.EscapeRecovery`` reads both through a callable the node supplies and drives the move one
control cycle at a time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.ndimage import distance_transform_edt

from common.config import param
from common.geometry import Pose2D
from master_side.costmap.cost_values import LETHAL, NO_INFORMATION
from master_side.planning.local.scoring_context import footprint_outline

ESCAPE_TYPES = ("zenav/EscapeRecovery", "EscapeRecovery")
STALL_BACKOFF = (0.1, 0.3)  # m, rad: the least drive or turn against a stalled command
IN_PLACE_V, IN_PLACE_W = 0.01, 0.05  # m/s, rad/s: slower than this, the command does not drive / turn

# (grid, resolution, origin, robot pose in the grid's frame) or None when the local costmap is not known
View = Callable[[], "tuple[np.ndarray, float, tuple[float, float], Pose2D] | None"]


@dataclass(frozen=True)
class EscapeParams:
    max_distance: float = param(0.3, lo=0.01, hi=2.0, unit="m", doc="longest straight drive, either way")
    max_turn: float = param(0.8, lo=0.0, hi=math.pi, unit="rad", doc="largest in-place turn, either way")
    clearance: float = param(0.15, lo=0.0, hi=2.0, unit="m",
                             doc="clearance of the outline that counts as free enough: the shortest move that "
                                 "reaches it wins over a longer move to more")
    speed: float = param(0.1, lo=0.01, hi=1.0, unit="m/s", doc="straight drive speed")
    turn_speed: float = param(0.4, lo=0.01, hi=5.0, unit="rad/s", doc="in-place turn speed")
    time_allowance: float = param(10.0, lo=0.1, hi=300.0, unit="s", doc="the move ends after this long")
    room_ahead: float = param(0.5, lo=0.0, hi=2.0, unit="m",
                              doc="when no move gains clearance, an obstacle nearer than this ahead of the "
                                  "robot's front, across its width, makes the longest reverse drive that loses "
                                  "none (a cell at most) the move (nav2's BackUp's role; a forward-only planner "
                                  "cannot back away); 0: never")
    turn_then_drive: bool = param(False, doc="also try an in-place turn followed by a straight drive: beside "
                                            "a wall along the flank a drive keeps the clearance and a turn "
                                            "brings a corner nearer, and only a drive at a slant gains it. Off "
                                            "by default: the turn sweeps the flanks, which a narrow forward "
                                            "sensor (the Kinect) does not see")
    sidestep: bool = param(True, doc="when no drive or turn gains clearance, also try a forward sidestep: an arc "
                                     "of radius 0.5 or 1 m away from the nearest wall and the same arc back, "
                                     "ending parallel to where it started (a robot beside a wall along its flank, "
                                     "a few cm off, where a drive keeps the clearance and a turn swings a corner "
                                     "into the wall)")
    stall_time: float = param(1.0, lo=0.1, hi=60.0, unit="s",
                              doc="the move ends when it has gained less than 2 cm or 0.05 rad in this long: "
                                  "something no sensor shows holds the robot")


SIDESTEP_RADII = (0.5, 1.0)  # m: the sidestep's arcs (0.6 m of them move the robot 0.18 / 0.09 m sideways)


@dataclass(frozen=True)
class EscapeMove:
    """A straight drive of ``distance`` m (negative: backwards), an in-place turn of ``turn`` rad, or (both
    set) the turn and then the drive on the heading it ends at; with ``curvature`` (1/m, positive: to the
    left) a sidestep: ``distance`` driven as an arc of that curvature for its first half and the opposite one
    for its second, ending on the heading it started at."""

    distance: float
    turn: float
    clearance_before: float
    clearance_after: float
    curvature: float = 0.0

    def describe(self) -> str:
        drive = f"{'forward' if self.distance > 0 else 'back'} {abs(self.distance):.2f} m"
        if self.curvature:
            side = "left" if self.curvature * self.distance > 0 else "right"
            return (f"sidestep {side} ({drive}, arcs of {1.0 / abs(self.curvature):.1f} m): clearance "
                    f"{self.clearance_before:.2f} -> {self.clearance_after:.2f} m")
        turn = f"turn {math.degrees(self.turn):+.0f} deg"
        what = f"{turn}, then {drive}" if self.distance and self.turn else drive if self.distance else turn
        return f"{what}: clearance {self.clearance_before:.2f} -> {self.clearance_after:.2f} m"


def arc_poses(pose: Pose2D, length: float, curvature: float, res: float, outline_r: float) -> np.ndarray:
    """(K, 3) poses along an arc of ``length`` m (negative: backwards) and ``curvature`` (1/m, positive: to
    the left going forward), dense enough that no outline point skips a cell."""
    n = max(1, int(math.ceil(abs(length) * (1.0 + abs(curvature) * outline_r) / (0.5 * res))))
    s = np.linspace(0.0, length, n + 1)[1:]
    th = pose.theta + curvature * s
    if abs(curvature) < 1e-9:
        return np.column_stack((pose.x + s * math.cos(pose.theta), pose.y + s * math.sin(pose.theta),
                                np.full_like(s, pose.theta)))
    return np.column_stack((pose.x + (np.sin(th) - math.sin(pose.theta)) / curvature,
                            pose.y - (np.cos(th) - math.cos(pose.theta)) / curvature, th))


def _poses_along(pose: Pose2D, distance: float, turn: float, res: float, outline_r: float,
                 center_x: float = 0.0, curvature: float = 0.0) -> np.ndarray:
    """(K, 3) poses from ``pose`` along the move, dense enough that no outline point skips a cell; a turn is
    about the point ``center_x`` ahead of base_link (the local planner's ``rotation_center_x``); a turn and a
    drive: the turn, then the drive from where it ends; ``curvature``: a sidestep (EscapeMove)."""
    if curvature:
        first = arc_poses(pose, 0.5 * distance, curvature, res, outline_r)
        return np.vstack((first, arc_poses(Pose2D(*(float(v) for v in first[-1])), 0.5 * distance, -curvature,
                                           res, outline_r)))
    if distance and turn:
        turned = _poses_along(pose, 0.0, turn, res, outline_r, center_x)
        end = Pose2D(*(float(v) for v in turned[-1]))
        return np.vstack((turned, _poses_along(end, distance, 0.0, res, outline_r, center_x)))
    if distance:
        return arc_poses(pose, distance, 0.0, res, outline_r)  # a straight drive: an arc of no curvature
    n = max(1, int(math.ceil(abs(turn) * (outline_r + abs(center_x)) / (0.5 * res))))
    a = np.linspace(0.0, turn, n + 1)[1:]
    px, py = pose.x + center_x * math.cos(pose.theta), pose.y + center_x * math.sin(pose.theta)  # turned about
    return np.column_stack((px - center_x * np.cos(pose.theta + a), py - center_x * np.sin(pose.theta + a),
                            pose.theta + a))


def _cells(poses: np.ndarray, outline: np.ndarray, res: float, origin: tuple[float, float]) -> np.ndarray:
    """(K, M, 2) integer (col, row) of every outline point at every pose."""
    c, s = np.cos(poses[:, 2])[:, None], np.sin(poses[:, 2])[:, None]
    x = poses[:, 0:1] + c * outline[None, :, 0] - s * outline[None, :, 1]
    y = poses[:, 1:2] + s * outline[None, :, 0] + c * outline[None, :, 1]
    return np.stack((np.floor((x - origin[0]) / res), np.floor((y - origin[1]) / res)), axis=-1).astype(np.int64)


def _inside(cells: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    return (cells[..., 0] >= 0) & (cells[..., 1] >= 0) & (cells[..., 0] < shape[1]) & (cells[..., 1] < shape[0])


def _outline(footprint: np.ndarray, res: float) -> tuple[np.ndarray, float]:
    """The outline's points, half a cell apart, and their largest distance from the robot's centre."""
    outline = footprint_outline(footprint, 0.5 * res)
    return outline, float(np.max(np.hypot(outline[:, 0], outline[:, 1])))


def _sweep(grid: np.ndarray, res: float, origin: tuple[float, float], pose: Pose2D, distance: float, turn: float,
           outline: np.ndarray, outline_r: float, center_x: float = 0.0,
           curvature: float = 0.0) -> tuple[np.ndarray | None, str]:
    """The outline's cells at every pose along the move, or None when one is lethal, unknown or off the grid;
    and what blocks it: "" (nothing), "off the costmap", "an obstacle", "unknown cells"."""
    return sweep_poses(grid, res, origin, _poses_along(pose, distance, turn, res, outline_r, center_x, curvature),
                       outline)


def sweep_poses(grid: np.ndarray, res: float, origin: tuple[float, float], poses: np.ndarray,
                outline: np.ndarray) -> tuple[np.ndarray | None, str]:
    """``_sweep`` over given poses (K, 3)."""
    cells = _cells(poses, outline, res, origin)
    if not _inside(cells, grid.shape).all():
        return None, "off the costmap"
    cost = grid[cells[..., 1], cells[..., 0]]
    if (cost == LETHAL).any():
        return None, "an obstacle"
    return (None, "unknown cells") if (cost == NO_INFORMATION).any() else (cells, "")


def _leaving(grid: np.ndarray, res: float, origin: tuple[float, float], pose: Pose2D,
             outline: np.ndarray) -> np.ndarray:
    """``grid`` with the lethal cells under the outline at ``pose`` freed: a robot touching a wall may move off
    it (every other cell of the way must be free; a move along or into the wall meets new lethal cells)."""
    cells = _cells(pose.as_array()[None], outline, res, origin)[0]
    cells = cells[_inside(cells, grid.shape)]
    touched = grid[cells[:, 1], cells[:, 0]] == LETHAL
    if not touched.any():
        return grid
    out = grid.copy()
    out[cells[touched, 1], cells[touched, 0]] = 0
    return out


def _against(d: float, a: float, cmd: tuple[float, float]) -> bool:
    """Does the drive ``d`` / turn ``a`` go against the stalled command's motion (and far enough)?"""
    v, w = cmd
    if d:
        return abs(v) >= IN_PLACE_V and d * v < 0 and abs(d) >= STALL_BACKOFF[0] - 1e-9
    return abs(w) >= IN_PLACE_W and a * w < 0 and abs(a) >= STALL_BACKOFF[1] - 1e-9


def move_kind(distance: float, turn: float, curvature: float = 0.0) -> tuple[float, float]:
    """(sign of the drive, sign of the turn): back, forward, a turn either way, or a turn then a drive; a
    sidestep: (sign of the drive, 2 x the sign of its first arc's curvature)."""
    if curvature:
        return math.copysign(1.0, distance), math.copysign(2.0, curvature)
    return (math.copysign(1.0, distance) if distance else 0.0, math.copysign(1.0, turn) if turn else 0.0)


def plan_escape(grid: np.ndarray, res: float, origin: tuple[float, float], pose: Pose2D, footprint: np.ndarray,
                params: EscapeParams = EscapeParams(), against: tuple[float, float] | None = None,
                why: list[str] | None = None, center_x: float = 0.0,
                exclude: frozenset[tuple[float, float]] = frozenset()) -> EscapeMove | None:
    """The shortest straight drive, in-place turn or turn then drive (a reverse drive counting double; a turn
    and a drive only if ``params.turn_then_drive``, and not against a stalled command) whose end leaves the
    robot's outline at least ``params.clearance`` from every lethal cell (else the one that leaves it
    farthest), free for the outline all the way (no lethal or unknown cell, not off the grid; a lethal cell
    the outline touches where the robot stands may be left behind). A move that gains less than a cell of
    clearance only when none gains a whole cell (a wall at a slant: 0.07 -> 0.09 m on a 2.5 cm grid, where
    office02's robot stood while DWA rejected every trajectory). None when the robot already has that
    clearance, or no move gains any and there is room ahead (``room_ahead`` below).

    ``against``: the (v, w) of a command the robot stalled on (move_base's stall_timeout): something the
    costmap does not show holds it, so the move goes the other way (a drive against v, or a turn against
    w), at least ``STALL_BACKOFF`` of it, whatever the clearance, the most clearance first.

    ``why``: when no move is found, a sentence saying why is appended to it (what blocked the moves, or the
    most clearance a free one reaches), for the log of a robot that stays where it is.

    ``center_x``: where on base_link's x axis the base turns about (a skid-steered base pivots toward its
    more loaded axle; the local planner's ``rotation_center_x``).

    ``exclude``: the kinds of move not to try, as (sign of the drive, sign of the turn): the escape's own
    moves that stalled where the robot stands (``EscapeRecovery``).

    When no move gains clearance and the robot does not back away for room (below), a forward sidestep
    that gains a whole cell is the move (``params.sidestep``, ``_sidestep``).

    When no move gains clearance but an obstacle lies within ``params.room_ahead`` of the robot's front
    (``room_ahead``), the longest free reverse drive that loses no clearance (a cell at most) is the move: a
    corridor's corner, a wall 0.3 m ahead and one 0.1 m beside the flank, leaves no turn and no forward arc
    free, and DWA driving forward only (while mapping) cannot back away to make room (office02, laser, 2026-11-30)."""
    grid = np.asarray(grid)
    outline, outline_r = _outline(footprint, res)
    way = _leaving(grid, res, origin, pose, outline)
    clear = distance_transform_edt(grid != LETHAL) * res if (grid == LETHAL).any() else np.full(grid.shape, np.inf)

    def clearance(cells: np.ndarray) -> float:
        ok = _inside(cells, grid.shape)
        return float(clear[cells[ok, 1], cells[ok, 0]].min()) if ok.any() else 0.0

    here = clearance(_cells(pose.as_array()[None], outline, res, origin)[0])
    if here >= params.clearance and against is None:
        if why is not None:
            why.append(f"free enough where it stands (clearance {here:.2f} m)")
        return None
    step = max(res, 0.05)
    dists = np.arange(step, params.max_distance + 1e-9, step)
    turns = np.arange(0.1, params.max_turn + 1e-9, 0.1)
    moves = [(s * d, 0.0) for d in dists for s in (-1.0, 1.0)] + [(0.0, s * a) for a in turns for s in (1.0, -1.0)]
    if params.turn_then_drive and against is None:
        moves += [(s * d, t * a) for a in turns for t in (1.0, -1.0) for d in dists for s in (-1.0, 1.0)]
    best: tuple[tuple[bool, float, float], EscapeMove] | None = None
    blocked: dict[str, int] = {}
    freest: EscapeMove | None = None  # the free move reaching the most clearance, gained or not
    # the longest free reverse drive that loses no clearance, within a cell: a wall along the flank at a slant
    # of a few degrees, nearer toward the rear, costs the rear corner a cell of the grid's rounding as it
    # backs (office02, Kinect, 2026-12-01: 0.10 -> 0.075 m over 0.3 m, a wall 0.14 m beyond the nose,
    # every trajectory rejected and three goals aborted there while backing 0.3 m was free)
    backing: EscapeMove | None = None
    for d, a in moves:
        if against is not None and not _against(float(d), float(a), against):
            continue
        if exclude and move_kind(float(d), float(a)) in exclude:
            blocked["stalled here before"] = blocked.get("stalled here before", 0) + 1
            continue
        cells, by = _sweep(way, res, origin, pose, float(d), float(a), outline, outline_r, center_x)
        if cells is None:
            blocked[by] = blocked.get(by, 0) + 1
            continue
        after = clearance(cells[-1])
        if freest is None or after > freest.clearance_after:
            freest = EscapeMove(float(d), float(a), here, after)
        if d < 0 and not a and after >= here - res - 1e-9 and (backing is None or d < backing.distance):
            backing = EscapeMove(float(d), 0.0, here, after)
        if after <= here + 1e-9 and against is None:
            continue
        # a whole cell gained first (a smaller gain only when none does), then the most clearance up to
        # params.clearance, then the least motion (a turn as its outline's arc; a reverse drive counts double:
        # behind the robot only sonars look, with gaps between their cones)
        key = (after >= here + res or against is not None, min(after, params.clearance),
               -((2.0 if d < 0 else 1.0) * abs(d) + abs(a) * outline_r))
        if best is None or key > best[0]:
            best = key, EscapeMove(float(d), float(a), here, after)
    if best is None and against is None and backing is not None and params.room_ahead > 0:
        ahead = room_ahead(grid, res, origin, pose, footprint, params.room_ahead)
        if ahead < params.room_ahead:
            if why is not None:
                why.append(f"backing away: no move gains clearance and an obstacle lies {ahead:.2f} m ahead")
            return backing
    if best is None and against is None and params.sidestep:
        # on the grid as it is: a robot touching a wall does not sidestep along it (the first arc would push
        # a corner deeper into the cells it touches)
        side = _sidestep(grid, res, origin, pose, outline, outline_r, here, clearance, params, exclude)
        if side is not None:
            return side
    if best is None and why is not None:
        why.append(_why_none(here, blocked, freest))
    return None if best is None else best[1]


def _sidestep(grid: np.ndarray, res: float, origin: tuple[float, float], pose: Pose2D, outline: np.ndarray,
              outline_r: float, here: float, clearance: Callable[[np.ndarray], float], params: EscapeParams,
              exclude: frozenset[tuple[float, float]]) -> EscapeMove | None:
    """The forward sidestep (SIDESTEP_RADII, up to twice ``max_distance`` long, a cell sideways at least) free
    all the way that gains a whole cell of clearance: the most clearance up to ``params.clearance``, then the
    shortest. Beside a wall along the flank, a few cm off, a drive keeps the clearance and any turn swings a
    corner into the wall; the first arc swings the rear corner toward it by at most 0.254^2 / 2 (R + 0.254)
    (2.6 cm for R = 1 m, 4.3 cm for 0.5 m) and the second brings the body parallel again, 0.09 / 0.18 m
    farther off after 0.6 m (office02, the Kinect robot, 2026-12-02: 5 cm off a wall along its right flank,
    every DWA trajectory rejected, no escape move, three goals aborted there and the run stuck). Forward
    only: the robot's sensors look forward."""
    step = max(res, 0.05)
    best: tuple[tuple[float, float], EscapeMove] | None = None
    for k in (s / r for r in SIDESTEP_RADII for s in (1.0, -1.0)):
        if move_kind(1.0, 0.0, k) in exclude:
            continue
        for d in np.arange(2 * step, 2 * params.max_distance + 1e-9, step):
            if 2.0 * (1.0 - math.cos(0.5 * d * k)) / abs(k) < res:  # less than a cell sideways: the grid's rounding
                continue
            cells, _ = _sweep(grid, res, origin, pose, float(d), 0.0, outline, outline_r, curvature=k)
            if cells is None:
                continue
            after = clearance(cells[-1])
            if after < here + res - 1e-9:
                continue
            key = (min(after, params.clearance), -float(d))
            if best is None or key > best[0]:
                best = key, EscapeMove(float(d), 0.0, here, after, k)
    return None if best is None else best[1]


def room_ahead(grid: np.ndarray, res: float, origin: tuple[float, float], pose: Pose2D, footprint: np.ndarray,
               reach: float) -> float:
    """How far ahead of the footprint's front the first LETHAL cell lies, within half a cell (the last free
    sample before it: a lower bound), across the footprint's width, each lateral row from the outline's own
    front there (the P3-AT's nose, or its body's front beside the nose); ``reach`` when there is none within
    ``reach`` or the strip leaves the grid there."""
    fp = np.asarray(footprint, float)
    half = float(np.abs(fp[:, 1]).max())
    lateral = np.linspace(-half, half, max(2, int(math.ceil(2 * half / (0.5 * res))) + 1))
    front = np.array([_front_at(fp, y) for y in lateral])
    s = np.arange(0.5 * res, reach + 1e-9, 0.5 * res)
    strip = np.column_stack(((front[None, :] + s[:, None]).ravel(), np.tile(lateral, len(s))))
    cells = _cells(pose.as_array()[None], strip, res, origin)[0]
    ok = _inside(cells, grid.shape)
    hit = np.zeros(len(cells), bool)
    hit[ok] = grid[cells[ok, 1], cells[ok, 0]] == LETHAL
    rows = hit.reshape(len(s), len(lateral)).any(axis=1)
    return float(s[np.argmax(rows)] - 0.5 * res) if rows.any() else reach


def _front_at(fp: np.ndarray, y: float) -> float:
    """The largest x of the polygon's outline at lateral position ``y`` (its edges crossing y)."""
    xs: list[float] = []
    for (ax, ay), (bx, by) in zip(fp, np.roll(fp, -1, axis=0)):
        if min(ay, by) - 1e-12 <= y <= max(ay, by) + 1e-12:
            xs.extend((ax, bx) if ay == by else (ax + (y - ay) / (by - ay) * (bx - ax),))
    return max(xs) if xs else float(fp[:, 0].max())


def _why_none(here: float, blocked: dict[str, int], freest: EscapeMove | None) -> str:
    """The sentence for a search that found no move: clearance here, the best free move, what blocked the rest."""
    counts = ", ".join(f"{n} by {by}" for by, n in sorted(blocked.items(), key=lambda kv: -kv[1]))
    if freest is None:
        return f"clearance {here:.2f} m where it stands; every move is blocked ({counts})"
    tail = f"; {sum(blocked.values())} moves blocked ({counts})" if blocked else ""
    return (f"clearance {here:.2f} m where it stands; the freest move, {freest.describe().split(':')[0]}, "
            f"reaches {freest.clearance_after:.2f} m{tail}")
