"""Local-costmap geometry for scoring: the scoring context, footprint helpers.

Path and goal distances are base_local_planner's MapGrid flood fills (``grid_distance``), computed
once per cycle on demand and cached in the context; a fill of one of the last few cycles with the same
costmap, plan (and footprint cells) is handed out again instead of being recomputed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from common.geometry import normalize_angles, points_in_polygon
from master_side.planning.local.goal_cell import _PREFIXES, pushed_goal_cell
from master_side.planning.local.grid_distance import _LATTICES, MapGrid, densify


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
    within_robot: bool = False  # cells under the current footprint are passable for the flood fills
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

    def set_plan(self, plan: np.ndarray) -> None:
        """Score against ``plan`` (its last pose the local goal) from here on: the plan's fills go, the
        grid's stay."""
        self.plan, self.goal = plan, plan[-1]
        self._cache = {k: v for k, v in self._cache.items() if k == "grid"}

    def map_grid(self) -> MapGrid:
        if "grid" not in self._cache:
            inside = footprint_cells(self.pose, self.footprint, self) if self.within_robot else None
            self._cache["grid"] = MapGrid(self.grid, self.resolution, self.origin, inside)
        return self._cache["grid"]

    def path_distance(self) -> np.ndarray:
        """(H, W) flood-fill cells to the plan (inf: obstacle or no way there)."""
        if "path" not in self._cache:  # with the goal distance: one graph for both fills
            self._cache["path"], self._cache[("goal", 0.0)] = self._recall(
                ("path", self.plan[:, :2].tobytes()), lambda: self.map_grid().distances(self.plan[:, :2]))
        return self._cache["path"]

    def goal_distance(self, front: float = 0.0) -> np.ndarray:
        """(H, W) flood-fill cells to the local goal; ``front`` > 0: of the plan whose last pose is
        pushed that far along the robot -> goal direction (DWA's goal_front costs)."""
        key = ("goal", float(front))
        if key == ("goal", 0.0):
            self.path_distance()
        if key not in self._cache:
            xy = self.plan[:, :2].copy()
            if front > 0.0 and len(xy):
                d = xy[-1] - self.pose[:2]
                a = math.atan2(d[1], d[0])
                xy[-1] += front * np.array([math.cos(a), math.sin(a)])
                # the pushed end moves with the robot; the fill only depends on the cell it leads to
                cell = pushed_goal_cell(self.grid, self.resolution, self.origin, self.plan[:, :2], xy[-1])
                targets = np.zeros(0, np.int64) if cell is None else np.array([cell])
                self._cache[key] = self._recall(
                    ("goal cell", cell), lambda: self.map_grid().lattice.fill(self.map_grid().passable, targets))
            else:
                self._cache[key] = self._recall(
                    ("goal", xy.tobytes()), lambda: self.map_grid().goal_distance(xy))
        return self._cache[key]

    def _recall(self, what: tuple, compute):
        """A flood fill of a recent cycle with the same costmap, plan and footprint cells, else compute."""
        robot = (self.pose.tobytes(), self.footprint.tobytes()) if self.within_robot else None
        key = (what, self.grid.tobytes(), self.grid.shape, self.resolution, self.origin.tobytes(), robot)
        got = _RECENT.pop(key, None)
        if got is None:
            got = compute()
            if len(_RECENT) >= 8:
                _RECENT.pop(next(iter(_RECENT), None), None)
        _RECENT[key] = got  # most recently used last
        return got


_RECENT: dict = {}  # flood fills of the last few cycles (the arrays are read-only)


def forget_recent_fills() -> None:
    """Drop the remembered flood fills (the next cycle computes its own; for benchmarks)."""
    _RECENT.clear()
    _PREFIXES.clear()
    for lattice in _LATTICES.values():
        lattice._recent.clear()


def footprint_cells(pose: np.ndarray, footprint: np.ndarray, ctx: ScoringContext) -> np.ndarray:
    """(H, W) bool: cells whose centre lies inside the footprint polygon at ``pose``, plus the cells
    under its outline (base_local_planner FootprintHelper::getFootprintCells with fill)."""
    mask = np.zeros(ctx.grid.shape, bool)
    fp = np.asarray(footprint, float).reshape(-1, 2)
    c, s = math.cos(pose[2]), math.sin(pose[2])
    world = fp @ np.array([[c, s], [-s, c]]) + pose[:2]
    r, cc, inside = ctx.cells(footprint_outline(world, ctx.resolution))
    mask[r[inside], cc[inside]] = True
    lo = np.floor((world.min(0) - ctx.origin) / ctx.resolution).astype(int)
    hi = np.floor((world.max(0) - ctx.origin) / ctx.resolution).astype(int)
    lo = np.maximum(lo, 0)
    hi = np.minimum(hi, np.array(ctx.grid.shape[::-1]) - 1)
    if (hi < lo).any():
        return mask
    cols, rows = np.meshgrid(np.arange(lo[0], hi[0] + 1), np.arange(lo[1], hi[1] + 1))
    centres = (np.column_stack((cols.ravel(), rows.ravel())) + 0.5) * ctx.resolution + ctx.origin
    hit = points_in_polygon(centres[:, 0], centres[:, 1], world)
    mask[rows.ravel()[hit], cols.ravel()[hit]] = True
    return mask


def footprint_outline(footprint: np.ndarray, spacing: float) -> np.ndarray:
    """Points along the closed footprint polygon, at most ``spacing`` apart (K, 2)."""
    fp = np.asarray(footprint, dtype=float).reshape(-1, 2)
    return densify(np.vstack((fp, fp[:1])), spacing)[:-1]


def angle_diff(a: np.ndarray | float, b: np.ndarray | float) -> Any:
    """Shortest signed angle a - b in [-pi, pi): a float for two scalars, else an ndarray."""
    d = normalize_angles(np.asarray(a) - np.asarray(b))
    return float(d) if np.ndim(d) == 0 else d
