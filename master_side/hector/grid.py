"""One level of hector's map: a fixed-size log-odds grid with bilinear interpolation and gradients.

Cell (col, row) covers [origin + col*res, origin + (col+1)*res) (rows are y, as ROS). For matching,
a cell's occupancy probability sits at the cell's centre and is interpolated bilinearly between the
four surrounding centres (hector's OccGridMapUtil interpolates between cell corners; centres keep
every level of the pyramid aligned with the others).
"""

from __future__ import annotations

import math

import numpy as np

from common.geometry import Pose2D
from common.messages import Header, OccupancyGrid

L_CLAMP = 50.0  # hector stops raising a cell's log-odds at 50


def log_odds(p: float) -> float:
    return math.log(p / (1.0 - p))


class GridLevel:
    def __init__(self, resolution: float, size: int, origin: tuple[float, float],
                 factor_free: float = 0.4, factor_occupied: float = 0.9, unknown: float = 0.5,
                 ignore_unknown: bool = False):
        self.res, self.size = float(resolution), int(size)
        self.ox, self.oy = float(origin[0]), float(origin[1])
        self.l_free, self.l_occ = log_odds(factor_free), log_odds(factor_occupied)
        self.logodds = np.zeros((self.size, self.size), np.float32)
        self.ignore_unknown = ignore_unknown
        self.prob = np.full((self.size, self.size), unknown, np.float32)
        self.flat_prob = self.prob.reshape(-1)  # a view: interpolation gathers from it

    # -- matching ------------------------------------------------------------------------------
    def interp(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Bilinear probability at world points and its gradient (per metre); 0 outside the map, or
        with ``ignore_unknown`` NaN where the nearest cell was never observed (no information)."""
        inv = 1.0 / self.res
        cx = (x - self.ox) * inv - 0.5
        cy = (y - self.oy) * inv - 0.5
        ix = np.floor(cx)
        iy = np.floor(cy)
        fx, fy = cx - ix, cy - iy
        n = self.size
        ok = (ix >= 0) & (iy >= 0) & (ix < n - 1) & (iy < n - 1)
        base = np.where(ok, iy * n + ix, 0).astype(np.intp)
        p = self.flat_prob
        i00, i10 = p[base], p[base + 1]
        i01, i11 = p[base + n], p[base + n + 1]
        gx, gy = 1.0 - fx, 1.0 - fy
        val = gy * (gx * i00 + fx * i10) + fy * (gx * i01 + fx * i11)
        dx = (gy * (i10 - i00) + fy * (i11 - i01)) * inv
        dy = (gx * (i01 - i00) + fx * (i11 - i10)) * inv
        if not ok.all():
            val, dx, dy = val * ok, dx * ok, dy * ok
        if self.ignore_unknown:
            near = base + (fy >= 0.5) * n + (fx >= 0.5)
            val = np.where(self.logodds.reshape(-1)[near] == 0, np.nan, val)
        return val, dx, dy

    # -- map update ----------------------------------------------------------------------------
    def update(self, origin: np.ndarray, ends: np.ndarray) -> None:
        """One scan from world point ``origin`` (2,) to world endpoints ``ends`` (N, 2): cells along
        each beam become freer once, endpoint cells more occupied once (a hit wins over a pass)."""
        if len(ends) == 0:
            return
        inv = 1.0 / self.res
        s = (np.asarray(origin, float) - (self.ox, self.oy)) * inv
        e = (ends - (self.ox, self.oy)) * inv
        n = self.size
        ecell = np.floor(e).astype(np.int64)
        okc = (ecell >= 0).all(axis=1) & (ecell < n).all(axis=1)
        occ = np.unique(ecell[okc, 1] * n + ecell[okc, 0])
        # free space: samples every half cell from the sensor to one cell before the endpoint
        d = e - s
        steps = np.maximum(np.ceil(2.0 * np.hypot(d[:, 0], d[:, 1])).astype(np.int64) - 1, 0)
        total = int(steps.sum())
        if total:
            beam = np.repeat(np.arange(len(e)), steps)
            k = np.arange(total) - np.repeat(np.cumsum(steps) - steps, steps)
            t = k / (steps[beam] + 1.0)
            fx = np.floor(s[0] + t * d[beam, 0]).astype(np.int64)
            fy = np.floor(s[1] + t * d[beam, 1]).astype(np.int64)
            okf = (fx >= 0) & (fy >= 0) & (fx < n) & (fy < n)
            free = np.unique(fy[okf] * n + fx[okf])
            free = free[~np.isin(free, occ, assume_unique=True)]
        else:
            free = np.zeros(0, np.int64)
        lo = self.logodds.reshape(-1)
        lo[free] = np.maximum(lo[free] + self.l_free, -L_CLAMP)
        lo[occ] = np.minimum(lo[occ] + self.l_occ, L_CLAMP)
        idx = np.concatenate((free, occ))
        self.flat_prob[idx] = 1.0 / (1.0 + np.exp(-lo[idx]))

    # -- output --------------------------------------------------------------------------------
    def occupancy_grid(self, stamp: float = 0.0, frame_id: str = "map", crop: bool = False,
                       margin: int = 10) -> OccupancyGrid:
        """ROS grid: -1 unknown (log-odds 0), 0 free, 100 occupied; ``crop`` to the known cells."""
        lo = self.logodds
        data = np.full(lo.shape, -1, np.int8)
        data[lo < 0] = 0
        data[lo > 0] = 100
        r0 = c0 = 0
        if crop:
            rows, cols = np.nonzero(lo)
            if len(rows):
                r0, c0 = max(rows.min() - margin, 0), max(cols.min() - margin, 0)
                r1, c1 = rows.max() + margin + 1, cols.max() + margin + 1
                data = data[r0:r1, c0:c1]
        return OccupancyGrid(Header(stamp, frame_id), self.res,
                             Pose2D(self.ox + c0 * self.res, self.oy + r0 * self.res, 0.0),
                             np.ascontiguousarray(data))
