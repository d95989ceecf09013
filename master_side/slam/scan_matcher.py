"""Scan-to-map matching: coarse-to-fine correlative search, then gmapping's hill climb.

The per-particle map window is turned into a likelihood field F = max over occupied cells of
exp(-d^2 / (2 match_sigma^2)) (support ``field_radius`` cells; separable because the Gaussian
factorises). A scan's score is the sum of F at its endpoints (as gmapping's score, with a kernel
about one cell wide so that the optimum is sharp); the weight uses gmapping's lsigma:
log p = sum(max(-d^2 / lsigma, floor)) with d recovered from F.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from master_side.slam.grid import Window
from master_side.slam.params import GMappingParams

COARSE = 4  # coarse level cell = COARSE fine cells


@dataclass
class Field:
    fine: np.ndarray  # (ny, nx) uint8 squared cell distance to the nearest hit (FAR: none, borders)
    coarse: np.ndarray  # (ny/COARSE, nx/COARSE) min-pooled fine field
    ix0: int
    iy0: int
    res: float
    table: np.ndarray  # (256,) float32 kernel value of a squared cell distance


@dataclass(frozen=True)
class MotionPrior:
    """The odometry prediction a match is pulled towards; weights in score per beam per m^2 / rad^2."""

    mean: np.ndarray  # (3,) x, y, theta
    translation_weight: float
    rotation_weight: float


FAR = 200  # "no occupied cell within the radius" in squared cells (uint8, no overflow when adding)


def squared_distance_field(occ: np.ndarray, radius: int) -> np.ndarray:
    """Squared cell distance to the nearest occupied cell (uint8), FAR beyond ``radius`` cells.

    Separable (squared distances add): a row pass then a column pass of shifted minima.
    """
    sq = np.arange(radius + 1, dtype=np.uint8) ** 2
    f = np.where(occ, np.uint8(0), np.uint8(FAR))
    g = f.copy()
    for d in range(1, radius + 1):
        np.minimum(g[:, d:], f[:, :-d] + sq[d], out=g[:, d:])
        np.minimum(g[:, :-d], f[:, d:] + sq[d], out=g[:, :-d])
    np.minimum(g, FAR, out=g)
    h = g.copy()
    for d in range(1, radius + 1):
        np.minimum(h[d:], g[:-d] + sq[d], out=h[d:])
        np.minimum(h[:-d], g[d:] + sq[d], out=h[:-d])
    h[h > radius * radius] = FAR
    h[0, :] = h[-1, :] = FAR
    h[:, 0] = h[:, -1] = FAR
    return h


def make_field(win: Window, p: GMappingParams) -> Field:
    fine = squared_distance_field(win.data > 0.0, p.field_radius)
    cols = fine[:, 0::COARSE].copy()
    for i in range(1, COARSE):
        np.minimum(cols, fine[:, i::COARSE], out=cols)
    coarse = cols[0::COARSE].copy()
    for i in range(1, COARSE):
        np.minimum(coarse, cols[i::COARSE], out=coarse)
    coarse[0, :] = coarse[-1, :] = FAR
    coarse[:, 0] = coarse[:, -1] = FAR
    table = np.exp(-np.arange(256) * win.res**2 / (2 * p.match_sigma**2)).astype(np.float32)
    table[FAR:] = 0.0
    return Field(fine, coarse, win.ix0, win.iy0, win.res, table)


def _rotated(pts: np.ndarray, thetas: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    c, s = np.cos(thetas)[:, None], np.sin(thetas)[:, None]
    return c * pts[None, :, 0] - s * pts[None, :, 1], s * pts[None, :, 0] + c * pts[None, :, 1]


def _grid_search(grid: np.ndarray, table: np.ndarray, cell: float, off: tuple[float, float],
                 pose: np.ndarray, pts: np.ndarray, thetas: np.ndarray,
                 half: int) -> tuple[np.ndarray, np.ndarray]:
    """Score pose + (i*cell, j*cell, theta) for |i|,|j| <= half, theta in ``thetas``.

    Returns (scores (A, T), translations (T, 2) in metres).
    """
    ny, nx = grid.shape
    rx, ry = _rotated(pts, thetas)
    qx = np.floor((rx + pose[0]) / cell - off[0]).astype(np.int64)  # (A, B)
    qy = np.floor((ry + pose[1]) / cell - off[1]).astype(np.int64)
    r = np.arange(-half, half + 1)
    tx, ty = np.repeat(r, r.size), np.tile(r, r.size)
    ix = np.clip(qx[:, None, :] + tx[None, :, None], 0, nx - 1)
    iy = np.clip(qy[:, None, :] + ty[None, :, None], 0, ny - 1)
    scores = table[np.take(grid, iy * nx + ix)].sum(axis=-1)
    return scores, np.column_stack((tx, ty)) * cell


def _bilinear_scores(fld: Field, poses: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Per-beam bilinearly interpolated field values for poses (K, 3): (K, B)."""
    f, res, ix0, iy0, tab = fld.fine, fld.res, fld.ix0, fld.iy0, fld.table
    ny, nx = f.shape
    rx, ry = _rotated(pts, poses[:, 2])
    u = (rx + poses[:, :1]) / res - ix0 - 0.5
    v = (ry + poses[:, 1:2]) / res - iy0 - 0.5
    u0, v0 = np.floor(u), np.floor(v)
    fu, fv = (u - u0).astype(np.float32), (v - v0).astype(np.float32)
    i0 = np.clip(u0.astype(np.int64), 0, nx - 2)
    j0 = np.clip(v0.astype(np.int64), 0, ny - 2)
    k = j0 * nx + i0
    flat = f.ravel()
    a, b, c, d = tab[flat[k]], tab[flat[k + 1]], tab[flat[k + nx]], tab[flat[k + nx + 1]]
    return (a * (1 - fu) + b * fu) * (1 - fv) + (c * (1 - fu) + d * fu) * fv


class ScanMatcher:
    def __init__(self, p: GMappingParams):
        self.p = p
        self.window = (p.search_linear, p.search_angular)
        self.prior: MotionPrior | None = None
        self.floor = -((p.field_radius * p.delta) ** 2) / p.lsigma

    def score(self, fld: Field, poses: np.ndarray, pts: np.ndarray) -> np.ndarray:
        """gmapping score (sum of exp(-d^2/sigma) over endpoints) of each pose (K, 3)."""
        return _bilinear_scores(fld, poses, pts).sum(axis=1)

    def log_likelihood(self, fld: Field, pose: np.ndarray, pts: np.ndarray) -> float:
        """Sum over beams of max(-d^2/lsigma, floor), d recovered from the field value."""
        f = _bilinear_scores(fld, pose[None, :], pts)[0]
        ll = (2 * self.p.match_sigma**2 / self.p.lsigma) * np.log(np.maximum(f, 1e-12))
        return float(np.maximum(ll, self.floor).sum())

    def _penalty(self, cand: np.ndarray, pose0: np.ndarray, n: int) -> np.ndarray:
        """Score units subtracted from a candidate pose: the motion prior (per beam, so that it
        competes with the fraction of beams a shift gains) or, without a prior, a weak pull to the
        search centre scaled by the window."""
        if self.prior is not None:
            m = self.prior.mean
            d2 = (cand[..., 0] - m[0]) ** 2 + (cand[..., 1] - m[1]) ** 2
            a = (cand[..., 2] - m[2] + np.pi) % (2 * np.pi) - np.pi
            return n * (self.prior.translation_weight * d2 + self.prior.rotation_weight * a * a)
        lin, ang = self.window
        d2 = (cand[..., 0] - pose0[0]) ** 2 + (cand[..., 1] - pose0[1]) ** 2
        d2 = d2 / max(lin, 1e-3) ** 2
        a = (cand[..., 2] - pose0[2] + np.pi) % (2 * np.pi) - np.pi
        return 0.05 * n * (d2 + (a / max(ang, 1e-3)) ** 2)

    def match(self, fld: Field, pose0: np.ndarray, pts: np.ndarray,
              window: tuple[float, float] | None = None,
              prior: MotionPrior | None = None) -> tuple[np.ndarray, float]:
        """Best pose near ``pose0`` for sensor-frame endpoints ``pts`` (B, 2); returns (pose, score).

        ``window`` = (linear m, angular rad) half-widths of the search (default: the params').
        ``prior``: candidates pay translation_weight * d^2 + rotation_weight * dtheta^2 per beam for
        leaving the odometry prediction (as Cartographer's scan matchers do), so a direction the
        scan does not constrain (a plain wall seen by a narrow sensor) follows odometry instead of
        sliding towards the part of the wall already in the map.
        The returned score is the plain match score (no penalty).
        """
        p, res = self.p, fld.res
        self.window = window or (p.search_linear, p.search_angular)
        self.prior = prior
        lin, ang = self.window
        n = len(pts)
        if n == 0:
            return pose0.copy(), 0.0
        best = pose0.astype(float).copy()
        # coarse: COARSE*res cells, 1 degree steps over the whole window
        if lin > 0 or ang > 0:
            cell = res * COARSE
            half = int(math.ceil(lin / cell))
            na = int(math.ceil(ang / math.radians(1.0)))
            th = best[2] + np.arange(-na, na + 1) * math.radians(1.0)
            off = (fld.ix0 / COARSE, fld.iy0 / COARSE)
            sc, tr = _grid_search(fld.coarse, fld.table, cell, off, best, pts, th, half)
            cand = np.empty(sc.shape + (3,))
            cand[..., 0] = best[0] + tr[None, :, 0]
            cand[..., 1] = best[1] + tr[None, :, 1]
            cand[..., 2] = th[:, None]
            sc = sc - self._penalty(cand, pose0, n)
            a, t = np.unravel_index(int(np.argmax(sc)), sc.shape)
            best = cand[a, t].copy()
            # fine: res cells, quarter-degree steps around the coarse winner
            th = best[2] + np.arange(-4, 5) * math.radians(0.25)
            sc, tr = _grid_search(fld.fine, fld.table, res, (fld.ix0, fld.iy0), best, pts, th,
                                  COARSE // 2 + 1)
            cand = np.empty(sc.shape + (3,))
            cand[..., 0] = best[0] + tr[None, :, 0]
            cand[..., 1] = best[1] + tr[None, :, 1]
            cand[..., 2] = th[:, None]
            sc = sc - self._penalty(cand, pose0, n)
            a, t = np.unravel_index(int(np.argmax(sc)), sc.shape)
            best = cand[a, t].copy()
        return self._hill_climb(fld, best, pose0, pts)

    def _hill_climb(self, fld: Field, pose: np.ndarray, pose0: np.ndarray,
                    pts: np.ndarray) -> tuple[np.ndarray, float]:
        """gmapping's optimizer: try +-x, +-y, +-theta; halve the steps when nothing improves."""
        n = len(pts)
        lstep, astep = min(self.p.lstep, fld.res) / 2, min(self.p.astep, math.radians(0.25)) / 2
        cur = self.score(fld, pose[None, :], pts)[0] - self._penalty(pose, pose0, n)
        refinements, steps = 0, 0
        moves = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
        while refinements <= self.p.iterations and steps < 200:
            steps += 1
            cand = pose[None, :] + moves * np.array([lstep, lstep, astep])
            sc = self.score(fld, cand, pts) - self._penalty(cand, pose0, n)
            k = int(np.argmax(sc))
            if sc[k] > cur:
                pose, cur = cand[k], sc[k]
            else:
                lstep, astep = lstep / 2, astep / 2
                refinements += 1
        pose = pose.copy()
        pose[2] = (pose[2] + np.pi) % (2 * np.pi) - np.pi
        return pose, float(self.score(fld, pose[None, :], pts)[0])
