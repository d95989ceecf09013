"""Scan-to-map matching: coarse-to-fine correlative search, then gmapping's hill climb.

The per-particle map window is turned into a likelihood field F = max over occupied cells of
exp(-d^2 / (2 match_sigma^2)) (support ``field_radius`` cells; see ``field.py``). A scan's score is
the sum of F at its endpoints (as gmapping's score, with a kernel about one cell wide so that the
optimum is sharp); the weight uses gmapping's lsigma: log p = sum(max(-d^2 / lsigma, floor)) with d
recovered from F.

Every step is vectorised across particles (one ``FieldSet`` holds all their fields in one flat
buffer) and across candidate poses and beams: the hill climbs of all particles run in lockstep,
each with its own step sizes and stop condition, so a filter update costs a few dozen numpy calls
whatever the particle count.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from common.geometry import normalize_angles
from master_side.slam import kernels
from master_side.slam.field import COARSE, PAD_C, PAD_F, Field, FieldSet, make_field
from master_side.slam.params import GMappingParams

__all__ = ["COARSE", "Field", "FieldSet", "MotionPrior", "ScanMatcher", "make_field"]
FINE_HALF = COARSE // 2 + 1  # fine search half-width in cells


@dataclass(frozen=True)
class MotionPrior:
    """The odometry prediction a match is pulled towards; weights in score per beam per m^2 / rad^2."""

    mean: np.ndarray  # (3,) x, y, theta  (or (P, 3) with (P,) weights for a batch)
    translation_weight: Any  # float, or (P,) ndarray for a batch
    rotation_weight: Any


def _rotated(pts: np.ndarray, thetas: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """pts (B, 2) rotated by thetas (...): (..., B) x and y."""
    c, s = np.cos(thetas)[..., None], np.sin(thetas)[..., None]
    return c * pts[:, 0] - s * pts[:, 1], s * pts[:, 0] + c * pts[:, 1]


def _grid_search(fs: FieldSet, coarse: bool, poses: np.ndarray, pts: np.ndarray, thetas: np.ndarray,
                 half: int, sel: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Score pose_p + (i*cell, j*cell, theta) for |i|,|j| <= half, theta in thetas[p] (P, A), pose p in
    field ``sel[p]`` (default: field p).

    Cells outside a particle's window score 0 (its border is FAR and the buffer is padded).
    Returns (scores (P, A, T), translations (T, 2) in metres).
    """
    if coarse:
        flat, off, w, nx, ny, pad = fs.coarse, fs.off_c, fs.w_c, fs.nx_c, fs.ny_c, PAD_C
        cell, ox, oy = fs.res * COARSE, fs.ix0 / COARSE, fs.iy0 / COARSE
    else:
        flat, off, w, nx, ny, pad = fs.fine, fs.off_f, fs.w_f, fs.nx_f, fs.ny_f, PAD_F
        cell, ox, oy = fs.res, fs.ix0.astype(float), fs.iy0.astype(float)
    assert 2 * half + 1 <= pad
    if sel is not None:
        off, w, nx, ny, ox, oy = (a[sel] for a in (off, w, nx, ny, ox, oy))
    scores = kernels.grid_search(flat, off, w, nx, ny, ox, oy, pad, cell, poses, np.cos(thetas), np.sin(thetas),
                                 pts, half)
    r = np.arange(-half, half + 1)
    return scores, np.column_stack((np.repeat(r, r.size), np.tile(r, r.size))) * cell


def _bilinear_scores(fs: FieldSet, poses: np.ndarray, pts: np.ndarray, sel: np.ndarray | None = None,
                     rotated: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """Per-beam bilinearly interpolated field values for poses (P, K, 3) of fields ``sel``: (P, K, B).
    ``rotated``: ``_rotated(pts, poses[..., 2])`` if at hand (overwritten)."""
    c = fs.consts if sel is None else fs.consts[sel]  # (P, 6): ix0, iy0, nx - 2, ny - 2, w, base
    ix0, iy0, nxm2, nym2, w, base = (c[:, i, None, None] for i in range(6))
    u, v = _rotated(pts, poses[..., 2]) if rotated is None else rotated
    i0 = j0 = None
    for q, p0, o, m in ((u, poses[..., :1], ix0, nxm2), (v, poses[..., 1:2], iy0, nym2)):
        q += p0  # in place: the same operations as (q + p0) / res - o - 0.5
        q /= fs.res
        q -= o
        q -= 0.5
        q0 = np.floor(q)
        q -= q0
        qi = q0.astype(np.int64)
        np.minimum(np.maximum(qi, 0, out=qi), m, out=qi)
        if i0 is None:
            i0 = qi
        else:
            j0 = qi
    fu, fv = u.astype(np.float32), v.astype(np.float32)
    k = j0 * w
    k += i0
    k += base
    f = fs.fine
    a, b = f.take(k), f.take(k + 1)
    k += w
    cc, d = f.take(k), f.take(k + 1)
    a *= 1 - fu  # (a (1 - fu) + b fu) (1 - fv) + (cc (1 - fu) + d fu) fv, with fewer temporaries
    b *= fu
    a += b
    cc *= 1 - fu
    d *= fu
    cc += d
    a *= 1 - fv
    cc *= fv
    a += cc
    return a


class ScanMatcher:
    grid_search = staticmethod(_grid_search)  # the correlative search's scoring (tests/slam's numpy reference swaps it)

    def __init__(self, p: GMappingParams):
        self.p = p
        self.floor = -((p.field_radius * p.delta) ** 2) / p.lsigma

    # -- scoring -----------------------------------------------------------------------------
    def score(self, fld: Field | FieldSet, poses: np.ndarray, pts: np.ndarray) -> np.ndarray:
        """gmapping score (sum of exp(-d^2/sigma) over endpoints) of each pose (K, 3) of one field."""
        return _bilinear_scores(FieldSet.of(fld), poses[None], pts)[0].sum(axis=1)

    def log_likelihood(self, fld: Field | FieldSet, pose: np.ndarray, pts: np.ndarray) -> float:
        """Sum over beams of max(-d^2/lsigma, floor), d recovered from the field value."""
        return float(self.log_likelihoods(FieldSet.of(fld), pose[None], pts)[0])

    def log_likelihoods(self, fs: FieldSet, poses: np.ndarray, pts: np.ndarray) -> np.ndarray:
        """log_likelihood of pose p (P, 3) in field p, for every p: (P,) float32."""
        f = _bilinear_scores(fs, poses[:, None, :], pts)[:, 0]
        ll = (2 * self.p.match_sigma**2 / self.p.lsigma) * np.log(np.maximum(f, 1e-12))
        return np.maximum(ll, self.floor).sum(axis=1)

    def _penalty(self, cand: np.ndarray, pose0: np.ndarray, n: int, window: tuple[float, float],
                 prior: MotionPrior | None) -> np.ndarray:
        """Score units subtracted from candidate poses cand (P, ..., 3) of particles p: the motion
        prior (per beam, so that it competes with the fraction of beams a shift gains) or, without
        a prior, a weak pull to the search centre pose0 (P, 3) scaled by the window."""
        e = (slice(None),) + (None,) * (cand.ndim - 2)
        if prior is not None:
            m = prior.mean
            d2 = (cand[..., 0] - m[:, 0][e]) ** 2 + (cand[..., 1] - m[:, 1][e]) ** 2
            a = normalize_angles(cand[..., 2] - m[:, 2][e])
            return n * (prior.translation_weight[e] * d2 + prior.rotation_weight[e] * a * a)
        lin, ang = window
        d2 = (cand[..., 0] - pose0[:, 0][e]) ** 2 + (cand[..., 1] - pose0[:, 1][e]) ** 2
        d2 = d2 / max(lin, 1e-3) ** 2
        a = normalize_angles(cand[..., 2] - pose0[:, 2][e])
        return 0.05 * n * (d2 + (a / max(ang, 1e-3)) ** 2)

    # -- matching ----------------------------------------------------------------------------
    def match(self, fld: Field | FieldSet, pose0: np.ndarray, pts: np.ndarray,
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
        if prior is not None:
            prior = MotionPrior(np.asarray(prior.mean, float)[None], np.array([prior.translation_weight]),
                                np.array([prior.rotation_weight]))
        poses, scores = self.match_many(FieldSet.of(fld), pose0[None], pts, window, prior)
        return poses[0], float(scores[0])

    def match_many(self, fs: FieldSet, pose0: np.ndarray, pts: np.ndarray,
                   window: tuple[float, float] | None = None,
                   prior: MotionPrior | None = None) -> tuple[np.ndarray, np.ndarray]:
        """``match`` of pose p (P, 3) in field p for every particle at once: (poses (P, 3), scores (P,)).
        ``prior``: mean (P, 3), weights (P,)."""
        p, res = self.p, fs.res
        window = window or (p.search_linear, p.search_angular)
        lin, ang = window
        n = len(pts)
        pose0 = np.asarray(pose0, float)
        if n == 0:
            return pose0.copy(), np.zeros(len(pose0))
        best = pose0.copy()
        if lin > 0 or ang > 0:
            # coarse: COARSE*res cells, 1 degree steps over the whole window
            half = int(math.ceil(lin / (res * COARSE)))
            na = int(math.ceil(ang / math.radians(1.0)))
            coarse_best, _ = self._search(fs, True, pose0, pose0, pts, np.arange(-na, na + 1) * math.radians(1.0),
                                          half, window, prior)
            # fine: res cells, quarter-degree steps, around the coarse winner and around the start pose
            # itself (where gmapping's hill climb begins). The coarse level's 4x4-cell maxima can rank a
            # wrong heading first (a turn at a corridor's end: 14 deg scored above the true 11 deg, which
            # then lay beyond the fine search's +-1 deg); the start's own neighbourhood keeps the match
            # from ending worse than a search that never left it.
            fine_th = np.arange(-4, 5) * math.radians(0.25)
            best, sc = self._search(fs, False, coarse_best, pose0, pts, fine_th, FINE_HALF, window, prior)
            moved = np.flatnonzero(np.any(coarse_best != pose0, axis=1))  # the others searched there already
            if len(moved):
                near, sc0 = self._search(fs, False, pose0[moved], pose0[moved], pts, fine_th, FINE_HALF, window,
                                         self.sub_prior(prior, moved), moved)
                keep = sc0 > sc[moved]
                best[moved[keep]] = near[keep]
        return self._hill_climb(fs, best, pose0, pts, window, prior)

    def _search(self, fs: FieldSet, coarse: bool, centre: np.ndarray, pose0: np.ndarray, pts: np.ndarray,
                dth: np.ndarray, half: int, window: tuple[float, float], prior: MotionPrior | None,
                sel: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The best of the grid of poses about ``centre`` (P, 3) (``half`` cells of the level each way,
        headings ``centre`` + ``dth``) by penalised score: (poses (P, 3), penalised scores (P,)). Pose p
        in field ``sel[p]`` (default p), ``prior`` and ``pose0`` already taken for those."""
        th = centre[:, 2:3] + dth[None, :]
        sc, tr = self.grid_search(fs, coarse, centre, pts, th, half, sel)
        cand = np.empty(sc.shape + (3,))
        cand[..., 0] = centre[:, None, None, 0] + tr[None, None, :, 0]
        cand[..., 1] = centre[:, None, None, 1] + tr[None, None, :, 1]
        cand[..., 2] = th[:, :, None]
        sc = (sc - self._penalty(cand, pose0, len(pts), window, prior)).reshape(len(sc), -1)
        k = sc.argmax(axis=1)
        rows = np.arange(len(sc))
        return cand.reshape(len(sc), -1, 3)[rows, k].copy(), sc[rows, k]

    def _hill_climb(self, fs: FieldSet, pose: np.ndarray, pose0: np.ndarray, pts: np.ndarray,
                    window: tuple[float, float], prior: MotionPrior | None) -> tuple[np.ndarray, np.ndarray]:
        """gmapping's optimizer: try +-x, +-y, +-theta; halve the steps when nothing improves
        (each particle on its own schedule; ``kernels.hill_climb``)."""
        lstep, astep = min(self.p.lstep, fs.res) / 2, min(self.p.astep, math.radians(0.25)) / 2
        if prior is None:
            pr = np.empty((0, 5))
        else:
            pr = np.column_stack((prior.mean, prior.translation_weight, prior.rotation_weight))
        lin, ang = window
        return kernels.hill_climb(fs.fine, fs.consts, np.ascontiguousarray(pose, float),
                                  np.ascontiguousarray(pose0, float), np.ascontiguousarray(pts, float), fs.res,
                                  lstep, astep, self.p.iterations, max(lin, 1e-3) ** 2, max(ang, 1e-3), pr)

    @staticmethod
    def sub_prior(prior: MotionPrior | None, idx: np.ndarray | slice) -> MotionPrior | None:
        """The batch prior of particles ``idx``."""
        if prior is None:
            return None
        return MotionPrior(prior.mean[idx], prior.translation_weight[idx], prior.rotation_weight[idx])
