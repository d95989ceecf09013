"""Local-costmap geometry for scoring: the scoring context, footprint helpers, plan distance maps.

Path distance stands in for base_local_planner's MapGrid (a BFS from the plan cells): here the exact
Euclidean distance to the local plan polyline, evaluated only at the points that are scored (cheaper
than a whole-grid transform; like the MapGrid it ignores obstacles, which ObstacleCost handles).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


@dataclass
class ScoringContext:
    """Everything a cost function may look at in one control cycle (local costmap frame)."""

    pose: np.ndarray  # (3,) x, y, theta
    vel: np.ndarray  # (3,) vx, vy, w (robot frame)
    grid: np.ndarray  # (H, W) uint8 costmap
    resolution: float
    origin: np.ndarray  # (2,) world x, y of the grid's corner
    footprint: np.ndarray  # (K, 2) polygon in the robot frame
    plan: np.ndarray  # (N, 3) the part of the global plan inside the local costmap, from the robot on
    goal: np.ndarray  # (3,) local goal: the last plan pose inside the local costmap
    _cache: dict = field(default_factory=dict, repr=False)

    def cells(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(row, col, inside) for world points (..., 2); row/col are 0 where outside."""
        return self.cells_xy(xy[..., 0], xy[..., 1])

    def cells_xy(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        inv = 1.0 / self.resolution
        big = 1 << 20  # shift so truncation toward zero is floor() for any map-sized offset
        c = ((x - self.origin[0]) * inv + big).astype(np.intp) - big
        r = ((y - self.origin[1]) * inv + big).astype(np.intp) - big
        h, w = self.grid.shape
        inside = (c >= 0) & (c < w) & (r >= 0) & (r < h)
        if not inside.all():
            r, c = np.where(inside, r, 0), np.where(inside, c, 0)
        return r, c, inside

    def plan_polyline(self) -> np.ndarray:
        """The local plan's (x, y) resampled to about two cells between vertices (cached)."""
        if "poly" not in self._cache:
            self._cache["poly"] = resample(self.plan[:, :2], 2.0 * self.resolution)
        return self._cache["poly"]


def resample(xy: np.ndarray, spacing: float) -> np.ndarray:
    """Keep the first and last points and those at least ``spacing`` (along the path) after the last kept."""
    xy = np.asarray(xy, dtype=float)
    if len(xy) < 3:
        return xy
    s = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))))
    keep = np.flatnonzero(np.diff(np.floor(s / spacing), prepend=-1.0) > 0)
    if keep[-1] != len(xy) - 1:
        keep = np.append(keep, len(xy) - 1)
    return xy[keep]


def polyline_distance(pts: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Distance from each of (P, 2) points to the polyline (N, 2)."""
    if len(poly) == 1:
        return np.hypot(pts[:, 0] - poly[0, 0], pts[:, 1] - poly[0, 1])
    a, ab = poly[:-1], np.diff(poly, axis=0)
    l2 = np.maximum((ab * ab).sum(1), 1e-12)
    dx = pts[:, None, 0] - a[None, :, 0]
    dy = pts[:, None, 1] - a[None, :, 1]
    t = np.clip((dx * ab[None, :, 0] + dy * ab[None, :, 1]) / l2[None, :], 0.0, 1.0)
    ex, ey = dx - t * ab[None, :, 0], dy - t * ab[None, :, 1]
    return np.sqrt((ex * ex + ey * ey).min(axis=1))


def densify(xy: np.ndarray, spacing: float) -> np.ndarray:
    """Insert points along a polyline so consecutive points are at most ``spacing`` apart."""
    xy = np.asarray(xy, dtype=float)
    if len(xy) < 2:
        return xy
    seg = np.diff(xy, axis=0)
    n = np.maximum(np.ceil(np.hypot(seg[:, 0], seg[:, 1]) / spacing).astype(int), 1)
    t = np.concatenate([np.arange(k) / k for k in n])
    i = np.repeat(np.arange(len(seg)), n)
    return np.vstack((xy[i] + seg[i] * t[:, None], xy[-1:]))


def footprint_outline(footprint: np.ndarray, spacing: float) -> np.ndarray:
    """Points along the closed footprint polygon, at most ``spacing`` apart (K, 2)."""
    fp = np.asarray(footprint, dtype=float).reshape(-1, 2)
    return densify(np.vstack((fp, fp[:1])), spacing)[:-1]


def footprint_radii(footprint: np.ndarray) -> tuple[float, float]:
    """(inscribed, circumscribed) radius of a footprint polygon around the robot origin."""
    fp = np.asarray(footprint, dtype=float).reshape(-1, 2)
    circ = float(np.max(np.hypot(fp[:, 0], fp[:, 1])))
    a, b = fp, np.roll(fp, -1, axis=0)
    ab = b - a
    t = np.clip(-(a * ab).sum(1) / np.maximum((ab * ab).sum(1), 1e-12), 0.0, 1.0)
    closest = a + ab * t[:, None]
    return float(np.min(np.hypot(closest[:, 0], closest[:, 1]))), circ


def angle_diff(a: np.ndarray | float, b: np.ndarray | float) -> np.ndarray | float:
    """Shortest signed angle a - b in [-pi, pi)."""
    d = (np.asarray(a) - np.asarray(b) + math.pi) % (2 * math.pi) - math.pi
    return float(d) if np.ndim(d) == 0 else d
