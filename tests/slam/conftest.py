"""Helpers for the SLAM tests: synthetic rooms and scans."""

from __future__ import annotations

import math

import numpy as np
import pytest

from common.geometry import Pose2D
from common.messages import Header, LaserScan


def _room_scan(pose: Pose2D, n: int = 360, half_w: float = 4.0, half_h: float = 3.0) -> LaserScan:
    """A 360-degree scan of a rectangular room (corners at ±half_w, ±half_h) with a box inside."""
    segs = [((-half_w, -half_h), (half_w, -half_h)), ((half_w, -half_h), (half_w, half_h)),
            ((half_w, half_h), (-half_w, half_h)), ((-half_w, half_h), (-half_w, -half_h)),
            ((1.0, 0.5), (2.0, 0.5)), ((2.0, 0.5), (2.0, 1.2)), ((2.0, 1.2), (1.0, 1.2)),
            ((1.0, 1.2), (1.0, 0.5))]
    inc = 2 * math.pi / n
    ang = -math.pi + inc * np.arange(n)
    best = ray_ranges(pose, ang + pose.theta, segs)
    return LaserScan(Header(0.0, "laser"), -math.pi, -math.pi + inc * (n - 1), inc, 0.0, 0.0, 0.05, 30.0,
                     best.astype(np.float32))


@pytest.fixture
def room_scan():
    """``room_scan(pose)`` -> LaserScan of a synthetic 8 m x 6 m room with a box."""
    return _room_scan


def ray_ranges(pose: Pose2D, angles: np.ndarray, segments) -> np.ndarray:
    """Distance from ``pose`` along each world-frame angle to the nearest segment ((x, y), (x, y)); inf if none."""
    d = np.column_stack((np.cos(angles), np.sin(angles)))
    o = np.array([pose.x, pose.y])
    best = np.full(len(angles), np.inf)
    for a, b in segments:
        a, b = np.asarray(a, float), np.asarray(b, float)
        e = b - a
        den = d[:, 0] * e[1] - d[:, 1] * e[0]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = ((a[0] - o[0]) * e[1] - (a[1] - o[1]) * e[0]) / den
            u = ((a[0] - o[0]) * d[:, 1] - (a[1] - o[1]) * d[:, 0]) / den
        ok = (np.abs(den) > 1e-12) & (t > 0) & (u >= 0) & (u <= 1)
        best[ok] = np.minimum(best[ok], t[ok])
    return best
