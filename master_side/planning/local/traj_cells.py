"""Costmap cells of trajectory points, computed once per trajectory set and shared by the costs.

Arrays are (T + 1, S): one row per step, so per-trajectory reductions run along the contiguous axis.
The cell arithmetic is ``ScoringContext.cells_xy``'s, so the cells are the same; "all inside" is
decided from the extreme coordinates, which float rounding keeps ordered (monotone operations).
"""

from __future__ import annotations

import numpy as np

from common.jit import kernel
from master_side.planning.local.scoring_context import ScoringContext
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
    h, w = ctx.grid.shape
    shape = np.shape(x)
    flat, inside, n_out = _cells(np.ravel(x), np.ravel(y), float(ctx.origin[0]), float(ctx.origin[1]),
                                 1.0 / ctx.resolution, h, w)
    flat = flat.reshape(shape)
    if inside_known or n_out == 0:
        return flat, None
    return flat, inside.reshape(shape)


@kernel
def _cells(x, y, ox, oy, inv, h, w):
    """flat cell index (0 where outside), inside flags and the count of points outside, in one pass;
    the cell of a coordinate is ``int32((v - origin) * inv + BIG) - BIG`` as in ``cells_xy``."""
    n = x.size
    flat = np.empty(n, np.int32)
    inside = np.empty(n, np.bool_)
    n_out = 0
    for i in range(n):
        cx = np.int32((x[i] - ox) * inv + BIG) - BIG
        cy = np.int32((y[i] - oy) * inv + BIG) - BIG
        ok = 0 <= cx < w and 0 <= cy < h
        inside[i] = ok
        if ok:
            flat[i] = cy * w + cx
        else:
            flat[i] = 0
            n_out += 1
    return flat, inside, n_out


def kernel_inside(inside: np.ndarray | None) -> tuple[np.ndarray, bool]:
    """``inside`` as a kernel takes it: (flags, True), or a dummy array and False when every cell is
    inside (a kernel argument cannot be None)."""
    return (inside, True) if inside is not None else (np.ones((1, 1), np.bool_), False)


def finite_end_values(d: np.ndarray, flat: np.ndarray, inside: np.ndarray | None, scale: float,
                      reject: float) -> np.ndarray:
    """(S,) ``d`` at each trajectory's last cell times ``scale``, or ``reject`` where any of its (T + 1, S)
    cells is outside (``inside`` False) or has a non-finite ``d``: one compiled pass, the values of
    ``where(all(isfinite(d[flat]) & inside), d[flat[-1]] * scale, reject)``."""
    return _finite_end_values(d, flat, *kernel_inside(inside), float(scale), float(reject))


@kernel
def _finite_end_values(d, flat, inside, has_inside, scale, reject):
    t1, s = flat.shape
    ok = np.ones(s, np.bool_)
    for k in range(t1):
        for j in range(s):
            if not np.isfinite(d[flat[k, j]]) or (has_inside and not inside[k, j]):
                ok[j] = False
    out = np.empty(s)
    for j in range(s):
        out[j] = d[flat[t1 - 1, j]] * scale if ok[j] else reject
    return out


def max_cell_values(g: np.ndarray, flat: np.ndarray, inside: np.ndarray | None, limit: int, reject: float
                    ) -> tuple[np.ndarray, bool]:
    """(S,) each trajectory's largest ``g`` over its (T + 1, S) cells as float, ``reject`` where a cell
    is outside or ``g >= limit``; and whether any first-row (start) cell is such a bad cell."""
    return _max_cell_values(g, flat, *kernel_inside(inside), limit, float(reject))


@kernel
def _max_cell_values(g, flat, inside, has_inside, limit, reject):
    t1, s = flat.shape
    top = np.zeros(s, g.dtype)
    bad = np.zeros(s, np.bool_)
    start_bad = False
    for k in range(t1):
        for j in range(s):
            v = g[flat[k, j]]
            if v > top[j]:
                top[j] = v
            if v >= limit or (has_inside and not inside[k, j]):
                bad[j] = True
                if k == 0:
                    start_bad = True
    out = np.empty(s)
    for j in range(s):
        out[j] = reject if bad[j] else float(top[j])
    return out, start_bad


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
