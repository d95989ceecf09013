"""The escape recovery's driving half: ``EscapeRecovery`` plans one move with ``escape.plan_escape`` when
move_base starts it, then commands that move one control cycle at a time, checking the robot's bare outline
a step ahead on the local costmap every tick (the planning half, and why the escape exists: escape.py)."""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from common.geometry import Pose2D, normalize_angle
from master_side.move_base.escape import (
    EscapeMove,
    EscapeParams,
    View,
    _leaving,
    _outline,
    _sweep,
    arc_poses,
    move_kind,
    plan_escape,
    sweep_poses,
)

PROGRESS = (0.02, 0.05)  # m, rad: a move that gains less than this in stall_time has stalled
SAME_PLACE = (0.05, 0.1)  # m, rad: a move that stalled is not tried again while the robot stays this near


class EscapeRecovery:
    """move_base recovery: plans one escape move on its first tick (``view`` gives the local costmap and
    the robot's pose in it), then drives it, checking the bare outline a step ahead every tick; done
    when the move is made, the way ahead is blocked, the time allowance is spent, the move stalls (something
    no sensor shows holds the robot: ``on_stall`` is told the command, as move_base's stall check would be,
    so that its stall marks show the local costmap where the robot pushed) or nothing helps. A kind of move
    that stalled (back, forward, a turn either way) is not planned again while the robot stays where it
    stalled: the same drive would stall the same way (office02, the Kinect robot, a front corner hooked on a
    wall's corner: 47 escapes backed 0.30 m and stalled at 0.00, 38 contacts at one place, 2026-12-01)."""

    def __init__(self, view: View, footprint: np.ndarray, params: EscapeParams | None = None,
                 name: str = "escape", log: Callable[[str], None] | None = None,
                 stalled: Callable[[], tuple[float, float] | None] | None = None,
                 on_stall: Callable[[tuple[float, float, float]], None] | None = None,
                 center_x: float = 0.0) -> None:
        """``stalled``: the (v, w) the robot stalled on when a stall started this recovery, else None;
        ``center_x``: where the base turns about (plan_escape)."""
        self._view, self.footprint, self.name = view, np.asarray(footprint, float), name
        self.params = params or EscapeParams()
        self.center_x = center_x
        self._log, self._stalled, self._on_stall = log, stalled, on_stall
        self.move: EscapeMove | None = None
        self._start: Pose2D | None = None
        self._t0 = 0.0
        self._done, self._done_time = 0.0, 0.0  # progress so far (m or rad) and when it last grew by PROGRESS
        self._turned = False  # a turn then a drive: the turn is made (self._start is then where the drive began)
        self._held: list[tuple[Pose2D, tuple[float, float]]] = []  # where a move stalled, and its kind

    def enabled(self, params) -> bool:
        return True

    def start(self, now: float) -> None:
        self._t0, self.move, self._start = now, None, None
        self._done, self._done_time, self._turned = 0.0, now, False
        view = self._view()
        against = self._stalled() if self._stalled is not None else None
        why: list[str] = [] if view is not None else ["no local costmap yet"]
        if view is not None:
            grid, res, origin, pose = view
            self._held = [(at, kind) for at, kind in self._held if at.distance(pose) <= SAME_PLACE[0]
                          and abs(normalize_angle(pose.theta - at.theta)) <= SAME_PLACE[1]]
            self.move = plan_escape(grid, res, origin, pose, self.footprint, self.params, against, why, self.center_x,
                                    frozenset(kind for _, kind in self._held))
            self._start = pose
        if self._log is not None:
            what = self.move.describe() if self.move else (
                "no free move against the stalled command" if against else
                "no move needed" if why and why[0].startswith("free enough") else "no move gains clearance")
            what += "".join(f" ({w})" for w in why)
            self._log(f"{self.name}: {what}" + (f" (stalled on v={against[0]:.2f}, w={against[1]:.2f})"
                                                 if against else ""))

    def step(self, now: float, pose: Pose2D, velocity) -> tuple[tuple[float, float, float], bool]:
        stop = (0.0, 0.0, 0.0)
        view = self._view()
        if self.move is None or self._start is None or view is None or now - self._t0 > self.params.time_allowance:
            return stop, True
        grid, res, origin, here = view
        m, p = self.move, self.params
        if m.curvature:
            return self._sidestep(now, grid, res, origin, here)
        if m.turn and m.distance and not self._turned and \
                abs(normalize_angle(self._start.between(here).theta)) >= abs(m.turn):  # the turn made: now the drive
            self._turned, self._start, self._done, self._done_time = True, here, 0.0, now
        leg_d, leg_a = (m.distance, 0.0) if self._turned or not m.turn else (0.0, m.turn)
        rel = self._start.between(here)
        # the way checked a step ahead, not beyond the leg's end (a turn's last step toward a wall it stops short of)
        if leg_d:
            left = abs(leg_d) - abs(rel.x)
            ahead = math.copysign(min(2 * res, max(left, 0.5 * res)), leg_d)
            cmd, check = (math.copysign(p.speed, leg_d), 0.0, 0.0), (ahead, 0.0)
        else:
            left = abs(leg_a) - abs(normalize_angle(rel.theta))
            ahead = math.copysign(min(0.1, max(left, 0.01)), leg_a)
            cmd, check = (0.0, 0.0, math.copysign(p.turn_speed, leg_a)), (0.0, ahead)
        done = abs(leg_d or leg_a) - left
        if done >= self._done + PROGRESS[0 if leg_d else 1]:
            self._done, self._done_time = done, now
        elif now - self._done_time > p.stall_time and left > 0.0:
            return self._stall(here, cmd, f"{done:.2f} of {abs(leg_d or leg_a):.2f} {'m' if leg_d else 'rad'}",
                               move_kind(m.distance, m.turn))
        way, outline, outline_r = self._way(grid, res, origin, here)
        if left <= 0.0 or _sweep(way, res, origin, here, *check, outline, outline_r, self.center_x)[0] is None:
            return stop, True
        return cmd, False

    def _way(self, grid, res: float, origin, here: Pose2D) -> tuple[np.ndarray, np.ndarray, float]:
        """(the grid the way ahead is checked on: the cells the outline touches at ``here`` freed, the outline,
        its radius)."""
        outline, outline_r = _outline(self.footprint, res)
        return _leaving(np.asarray(grid), res, origin, here, outline), outline, outline_r

    def _stall(self, here: Pose2D, cmd: tuple[float, float, float], progress: str,
               kind: tuple[float, float]) -> tuple[tuple[float, float, float], bool]:
        """End the move as stalled after ``progress`` ("0.05 of 0.30 m"): log it, tell ``on_stall`` the command,
        and hold that ``kind`` of move where the robot stands."""
        if self._log is not None:
            self._log(f"{self.name}: stalled after {progress}: something no sensor shows holds the robot")
        if self._on_stall is not None:
            self._on_stall(cmd)
        self._held.append((here, kind))
        return (0.0, 0.0, 0.0), True

    def _sidestep(self, now: float, grid, res: float, origin, here: Pose2D) -> tuple[tuple[float, float, float], bool]:
        """A sidestep's tick: the first arc until the heading has turned by half the move's arc length times
        its curvature, then the opposite arc until the heading is back where it started; progress and the way
        a step ahead as for a drive (the arc length, from the heading turned)."""
        m, p, stop = self.move, self.params, (0.0, 0.0, 0.0)
        assert m is not None and self._start is not None
        half = 0.5 * abs(m.distance) * abs(m.curvature)  # rad each arc turns
        turned = abs(normalize_angle(here.theta - self._start.theta))
        if not self._turned and turned >= half:  # the first arc made: the second from here
            self._turned, self._start, self._done, self._done_time = True, here, 0.0, now
            turned = 0.0
        k = -m.curvature if self._turned else m.curvature
        left = (half - turned) / abs(k)  # m of this arc to go
        done = 0.5 * abs(m.distance) - left + (0.5 * abs(m.distance) if self._turned else 0.0)
        v = math.copysign(p.speed, m.distance)
        cmd = (v, 0.0, v * k)
        if done >= self._done + PROGRESS[0]:
            self._done, self._done_time = done, now
        elif now - self._done_time > p.stall_time and left > 0.0:
            return self._stall(here, cmd, f"{done:.2f} of {abs(m.distance):.2f} m",
                               move_kind(m.distance, 0.0, m.curvature))
        way, outline, outline_r = self._way(grid, res, origin, here)
        ahead = math.copysign(min(2 * res, max(left, 0.5 * res)), m.distance)
        if left <= 0.0 or sweep_poses(way, res, origin, arc_poses(here, ahead, k, res, outline_r), outline)[0] is None:
            return stop, True
        return cmd, False
