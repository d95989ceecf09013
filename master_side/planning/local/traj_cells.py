"""Costmap cells of trajectory points, computed once per trajectory set and shared by the costs.

Arrays are (T + 1, S): one row per step, so per-trajectory reductions run along the contiguous axis.
The cell arithmetic is ``ScoringContext.cells_xy``'s, so the cells are the same; "all inside" is
decided from the extreme coordinates, which float rounding keeps ordered (monotone operations).
"""

from __future__ import annotations

import numpy as np

from master_side.planning.local.map_grid import ScoringContext
from master_side.planning.local.trajectories import Trajectories

BIG = 1 << 20  # as in ScoringContext.cells_xy: truncation of a shifted value is floor()


def steps_xy(trajs: Trajectories) -> tuple[np.ndarray, ...]:
    """(x, y, theta, cos theta, sin theta), each (T + 1, S); theta is None for a simulated set (no cost
    reads it)."""
    got = trajs.cache.get("xyT")
    if got is None:
        p = trajs.poses
        th = np.ascontiguousarray(p[:, :, 2].T)
        got = (np.ascontiguousarray(p[:, :, 0].T), np.ascontiguousarray(p[:, :, 1].T), th, np.cos(th), np.sin(th))
        trajs.cache["xyT"] = got
    return got


def _cache(trajs: Trajectories, ctx: ScoringContext) -> dict:
    """The set's cache of cells, emptied when asked about another context (map) than last time."""
    cache = trajs.cache
    if cache.get("ctx") is not ctx:
        for key in [k for k in cache if k != "xyT"]:
            del cache[key]
        cache["ctx"] = ctx
    return cache


def _points(trajs: Trajectories, forward: float, rows=slice(None)) -> tuple[np.ndarray, np.ndarray]:
    x, y, _, c, s = steps_xy(trajs)
    if forward == 0.0:
        return x[rows], y[rows]
    return x[rows] + forward * c[rows], y[rows] + forward * s[rows]


def flat_cells(ctx: ScoringContext, x: np.ndarray, y: np.ndarray, inside_known: bool = False
               ) -> tuple[np.ndarray, np.ndarray | None]:
    """(flat cell index, inside) of world points; inside None when every point is inside (or the caller
    knows they are: ``inside_known``); the index is 0 where outside."""
    inv = 1.0 / ctx.resolution
    h, w = ctx.grid.shape
    cx = ((x - ctx.origin[0]) * inv + BIG).astype(np.int32)  # exact: |values| < 2^31
    cy = ((y - ctx.origin[1]) * inv + BIG).astype(np.int32)
    cx -= BIG
    cy -= BIG
    flat = cy * w
    flat += cx
    if inside_known or cx.size == 0 or (cx.min() >= 0 and cx.max() < w and cy.min() >= 0 and cy.max() < h):
        return flat, None
    inside = (cx >= 0) & (cx < w) & (cy >= 0) & (cy < h)
    flat[~inside] = 0
    return flat, inside


def point_cells(trajs: Trajectories, ctx: ScoringContext, forward: float = 0.0):
    """(flat, inside | None) of every point (``forward`` m ahead of each pose), (T + 1, S)."""
    cache, key = _cache(trajs, ctx), ("cells", forward)
    if key not in cache:
        cache[key] = flat_cells(ctx, *_points(trajs, forward))
    return cache[key]


def last_cells(trajs: Trajectories, ctx: ScoringContext, forward: float = 0.0):
    """(flat, inside | None) of the last point of each trajectory, (S,)."""
    cache, key = _cache(trajs, ctx), ("cells", forward)
    if key in cache:
        flat, inside = cache[key]
        return flat[-1], None if inside is None else inside[-1]
    if ("last", forward) not in cache:
        cache[("last", forward)] = flat_cells(ctx, *_points(trajs, forward, -1))
    return cache[("last", forward)]


def all_inside(trajs: Trajectories, ctx: ScoringContext, forward: float = 0.0) -> np.ndarray:
    """(S,) bool: every point of the trajectory lies on the map."""
    cache, key = _cache(trajs, ctx), ("all inside", forward)
    if key not in cache:
        cache[key] = _all_inside(trajs, ctx, forward)
    return cache[key]


def _all_inside(trajs: Trajectories, ctx: ScoringContext, forward: float) -> np.ndarray:
    n = len(trajs)
    if ("cells", forward) not in trajs.cache and n:
        x, y = steps_xy(trajs)[:2]
        inv, big = 1.0 / ctx.resolution, float(BIG)
        h, w = ctx.grid.shape
        # x + f cos(th) lies in [x - f, x + f] after rounding too, and so do the shifted cell values
        f = abs(forward)
        lo_x = ((x.min() - f) - ctx.origin[0]) * inv + big
        hi_x = ((x.max() + f) - ctx.origin[0]) * inv + big
        lo_y = ((y.min() - f) - ctx.origin[1]) * inv + big
        hi_y = ((y.max() + f) - ctx.origin[1]) * inv + big
        if lo_x >= big and hi_x < big + w and lo_y >= big and hi_y < big + h:
            return np.ones(n, bool)
    inside = point_cells(trajs, ctx, forward)[1]
    return np.ones(n, bool) if inside is None else inside.all(axis=0)
