"""Obstacle points the sensor can no longer see, remembered in the odometry frame.

A Kinect sees nothing closer than about 0.45 m; a narrow laser sees nothing beside the robot. A wall
the robot drives up to leaves the scan just when it matters. ``PointMemory`` keeps each source's
points in the odom frame; a new scan replaces every remembered point its beams measured again or
looked through (what the sensor sees now is the truth there). It keeps the others: for as long as the
beam toward them returns nothing (a depth camera's answer for an obstacle too close to it), and for
``max_age`` seconds when they are outside the field of view or hidden behind something nearer.
Pure numpy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from common.geometry import Pose2D

__all__ = ["PointMemory", "View"]


@dataclass(frozen=True)
class View:
    """What a scan measured: its sensor pose in odom and its beams."""

    sensor: Pose2D
    angle_min: float
    angle_increment: float
    ranges: np.ndarray
    tolerance: float = 0.05  # m

    def classify(self, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """For odom points (N, 2): (seen, blind). ``seen``: the beam toward the point returned at least
        as far - measured again or looked through, the scan is the truth there. ``blind``: inside the
        field of view but the beam returned nothing - what a depth camera gives for an obstacle too
        close to it, so the point is still believed."""
        n = len(pts)
        if n == 0 or len(self.ranges) == 0 or self.angle_increment == 0:
            return np.zeros(n, bool), np.zeros(n, bool)
        local = self.sensor.inverse().apply(pts)
        r = np.hypot(local[:, 0], local[:, 1])
        idx = np.round((np.arctan2(local[:, 1], local[:, 0]) - self.angle_min) / self.angle_increment)
        ok = (idx >= 0) & (idx < len(self.ranges))
        beam = np.full(n, np.nan)
        beam[ok] = self.ranges[idx[ok].astype(np.int64)]
        finite = np.isfinite(beam)
        with np.errstate(invalid="ignore"):
            seen = ok & finite & (beam >= r - self.tolerance)
        return seen, ok & ~finite


class PointMemory:
    def __init__(self, max_age: float) -> None:
        self.max_age = max_age
        self.pts = np.zeros((0, 2))
        self.t = np.zeros(0)
        self.current = np.zeros((0, 2))
        self.current_t = 0.0

    def update(self, pts_odom: np.ndarray, view: View, now: float) -> None:
        """A new scan: its points (N, 2, odom) become current; the previous points leave for memory
        unless the new scan covers their place."""
        old = np.vstack([self.pts, self.current])
        t = np.concatenate([self.t, np.full(len(self.current), self.current_t)])
        if self.max_age > 0:
            seen, blind = view.classify(old)
            t = np.where(blind, now, t)  # still in the blind zone: still believed
            keep = ~seen & (now - t <= self.max_age)
        else:
            keep = np.zeros(len(old), bool)
        self.pts, self.t = old[keep], t[keep]
        self.current = np.asarray(pts_odom, float).reshape(-1, 2)
        self.current_t = now

    def points(self) -> np.ndarray:
        """Current and remembered points (odom)."""
        return np.vstack([self.current, self.pts])
