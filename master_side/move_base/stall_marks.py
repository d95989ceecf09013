"""Where a stall says a flank touches something: points for the local costmap to mark (zenav's ``stall_marks``).

A P3-AT's bumpers cover its front and rear faces; nothing senses its flanks. Exploring office02, a wall beside
the flank, seen ahead minutes before, had left the local costmap (freed with the padded footprint, as ROS
frees it, or by rays passing along it), and DWA turned the flank into it again and again: 31 contacts at one
place, each stall's escape moving the robot off and the next DWA command turning it back in.

A stall (move_base's ``stall_timeout``) tells what command got the robot nowhere. A point of the outline
pushes outwards under that command where its velocity ``(v - w y, w (x - cx))`` (a base turning about the point
``cx`` of its x axis, the local planner's ``rotation_center_x``) has a positive component along the
outline's outward normal; on a flank (an edge whose normal is mostly across the robot) those points are where
the unseen wall can be. Each gets a point ``offset`` beyond it, outside the padded footprint (which the
obstacle layer frees), as a bumper press does (robot_side/bumpers/geometry.py). The planner then keeps away
from turning that flank outwards; a pure forward or backward command pushes no flank and marks nothing.
Pure: no bus.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

LEAD_SHARE = 0.25  # points pushing outwards at least this share of the fastest flank point are marked


def flank_push_points(footprint: np.ndarray, v: float, w: float, offset: float = 0.08, spacing: float = 0.05,
                      z: float = 0.1, center_x: float = 0.0) -> np.ndarray:
    """(N, 3) float32 points in the base frame, ``offset`` beyond the flank points the command (v, w) pushes
    outwards (a convex footprint polygon (K, 2), either winding); empty when it pushes no flank."""
    fp = np.asarray(footprint, float).reshape(-1, 2)
    area2 = float(np.sum(fp[:, 0] * np.roll(fp[:, 1], -1) - np.roll(fp[:, 0], -1) * fp[:, 1]))
    sign = 1.0 if area2 > 0 else -1.0  # counter-clockwise: the outward normal of edge (dx, dy) is (dy, -dx)
    points, normals = [], []
    for a, b in zip(fp, np.roll(fp, -1, axis=0)):
        d = b - a
        length = float(np.hypot(*d))
        if length == 0.0:
            continue
        n = sign * np.array([d[1], -d[0]]) / length
        if abs(n[1]) <= abs(n[0]):  # a front or rear face: the bumpers' job
            continue
        k = max(int(np.ceil(length / spacing)), 1)
        t = (np.arange(k) + 0.5) / k  # the edge's inner points: a corner belongs to both faces
        points.append(a + t[:, None] * d)
        normals.append(np.repeat(n[None], k, axis=0))
    if not points:
        return np.zeros((0, 3), np.float32)
    p, n = np.vstack(points), np.vstack(normals)
    lead = (v - w * p[:, 1]) * n[:, 0] + w * (p[:, 0] - center_x) * n[:, 1]
    top = float(lead.max())
    if top <= 1e-6:
        return np.zeros((0, 3), np.float32)
    keep = lead >= LEAD_SHARE * top
    out = p[keep] + offset * n[keep]
    return np.column_stack((out, np.full(len(out), z))).astype(np.float32)


class StallMarker:
    """Sends a new stall's points once (``send(points, now)``), and an empty cloud ``CLEAR_AFTER_S`` later: the
    obstacle layer keeps re-marking a source's latest reading, so the marks then stay only until a sensor's
    rays clear them. Between stalls an empty cloud every ``KEEPALIVE_S``: a costmap reports a source it never
    heard from as silent (costmap/health.py), and move_base would not drive on it."""

    CLEAR_AFTER_S = 1.0
    KEEPALIVE_S = 1.0

    def __init__(self, footprint: np.ndarray, send: Callable[[np.ndarray, float], None],
                 center_x: float = 0.0) -> None:
        self.footprint = np.asarray(footprint, float)
        self.center_x = center_x
        self.send = send
        self.seen = 0
        self.marked_at: float | None = None  # when the last marks went out (None: cleared since)
        self.sent_at = float("-inf")

    def tick(self, now: float, stalls: int, command: tuple[float, float, float] | None) -> None:
        """One control cycle: ``stalls`` counts the stalls so far, ``command`` is the last one's (v, vy, w)."""
        if stalls != self.seen and command is not None:
            self.seen = stalls
            points = flank_push_points(self.footprint, command[0], command[2], center_x=self.center_x)
            if len(points):
                self._send(points, now)
                self.marked_at = now
                return
        if self.marked_at is not None:
            if now - self.marked_at >= self.CLEAR_AFTER_S:
                self._send(np.zeros((0, 3), np.float32), now)
                self.marked_at = None
        elif now - self.sent_at >= self.KEEPALIVE_S:
            self._send(np.zeros((0, 3), np.float32), now)

    def _send(self, points: np.ndarray, now: float) -> None:
        self.send(points, now)
        self.sent_at = now
