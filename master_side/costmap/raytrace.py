"""Vectorised ray traversal over grids of any dimension: all rays of an observation at once.

Rays go from one start to many ends in *cell units* (float coordinates, cell i covers [i, i + 1)).
Each ray visits max(|delta|) + 1 cells along the line (a DDA equivalent to Bresenham's 8-connected line);
the end cell is excluded (it holds the hit) unless the ray was cut short by the grid or a range limit.
"""

from __future__ import annotations

import numpy as np

EPS = 1e-6


def clip_rays(start: np.ndarray, ends: np.ndarray, shape: tuple[int, ...], t_limit: np.ndarray) -> np.ndarray:
    """Fraction t in [0, 1] of each ray start -> end that stays inside [0, shape) and under ``t_limit``."""
    d = ends - start
    t = np.minimum(np.asarray(t_limit, float), 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        for k, n in enumerate(shape):
            up = np.where(d[:, k] > 0, (n - EPS - start[k]) / d[:, k], np.inf)
            down = np.where(d[:, k] < 0, -start[k] / d[:, k], np.inf)
            t = np.minimum(t, np.minimum(up, down))
    return np.clip(t, 0.0, 1.0)


def trace_cells(start: np.ndarray, ends: np.ndarray, shape: tuple[int, ...],
                t_limit: np.ndarray | float = 1.0) -> tuple[np.ndarray, ...]:
    """Integer cell coordinates (one int array per dimension) crossed by the rays start (D,) -> ends (R, D).

    ``start`` must be inside the grid. ``t_limit`` (per ray or scalar) shortens rays (range limits).
    A cell crossed by several rays appears several times.
    """
    dims = len(shape)
    start = np.asarray(start, float)
    ends = np.asarray(ends, float).reshape(-1, dims)
    if len(ends) == 0:
        return tuple(np.zeros(0, np.intp) for _ in range(dims))
    t = clip_rays(start, ends, shape, np.broadcast_to(np.asarray(t_limit, float), (len(ends),)))
    cut = t < 1.0
    stop = start + (ends - start) * t[:, None]
    c0 = np.floor(start).astype(np.intp)
    c1 = np.clip(np.floor(stop).astype(np.intp), 0, np.asarray(shape) - 1)
    delta = c1 - c0
    n = np.abs(delta).max(axis=1)
    count = n + cut  # a cut ray also clears its last cell (nothing was hit there)
    total = int(count.sum())
    if total == 0:
        return tuple(np.zeros(0, np.intp) for _ in range(dims))
    # k = step index along its own ray, for all rays concatenated (float32: exact for k < 2**24)
    k = np.arange(total, dtype=np.float32) - np.repeat((np.cumsum(count) - count).astype(np.float32), count)
    step = (delta / np.maximum(n, 1)[:, None]).astype(np.float32)
    out = []
    for d in range(dims):
        v = np.repeat(step[:, d], count)
        v *= k
        out.append(np.rint(v, out=v).astype(np.intp) + c0[d])
    return tuple(out)
