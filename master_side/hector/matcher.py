"""Gauss-Newton scan-to-map matching (hector's ScanMatcher), coarse level to fine level.

The pose ξ = (x, y, θ) minimises Σ (1 − M(S_i(ξ)))² where M is the bilinearly interpolated map
probability and S_i(ξ) the i-th scan point in the world; each step solves H Δξ = Σ ∇Mᵀ ∂S_i/∂ξ ·
(1 − M) with H = Σ (∇M ∂S_i/∂ξ)ᵀ (∇M ∂S_i/∂ξ) (the Gauss-Newton Hessian).
"""

from __future__ import annotations

import math

import numpy as np

from master_side.hector.grid import GridLevel

MAX_ROT_STEP = 0.2  # rad per iteration, as hector clamps it
MAX_STEP_CELLS = 2.0  # translation per iteration, in cells of the level
H_FLOOR = 1e-6  # relative damping: keeps a degenerate Hessian (a bare wall, an empty map) invertible


def _linearise(level: GridLevel, px: np.ndarray, py: np.ndarray, pose: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray]:
    """Residuals 1 − M and their Jacobian (N, 3) at ``pose``."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    rx, ry = c * px - s * py, s * px + c * py  # rotated points
    m, dx, dy = level.interp(pose[0] + rx, pose[1] + ry)
    bad = np.isnan(m)  # the nearest cell never observed (ignore_unknown): no residual, no gradient
    if bad.any():
        m, dx, dy = np.where(bad, 1.0, m), np.where(bad, 0.0, dx), np.where(bad, 0.0, dy)
    j = np.empty((len(px), 3))
    j[:, 0], j[:, 1] = dx, dy
    j[:, 2] = -ry * dx + rx * dy
    return 1.0 - m, j


def gauss_newton(level: GridLevel, pts: np.ndarray, pose: np.ndarray, iterations: int,
                 prior_w: np.ndarray | None = None, anchor: np.ndarray | None = None
                 ) -> tuple[np.ndarray, np.ndarray, float]:
    """Refine ``pose`` (x, y, θ) matching base-frame ``pts`` (N, 2) on one level.

    A step that raises the cost is halved (and the iteration spent) instead of taken, and a step
    moves at most ``MAX_STEP_CELLS`` cells and ``MAX_ROT_STEP`` rad: a flat or degenerate part of the
    map cannot throw the pose away. ``prior_w`` (3,): weights of a soft prior (Δx², Δy², Δθ²) keeping
    the pose near ``anchor`` (the prediction; default the starting pose) in directions the map does
    not constrain, e.g. along a corridor whose end is out of range.
    Returns (pose, Hessian at the final pose, mean squared residual)."""
    pose = np.array(pose, float)
    px, py = pts[:, 0], pts[:, 1]
    start = pose.copy() if anchor is None else np.asarray(anchor, float)
    w = np.zeros(3) if prior_w is None else np.asarray(prior_w, float)

    def total(pose_: np.ndarray, r_: np.ndarray) -> float:
        d = pose_ - start
        return float(r_ @ r_) + float(w @ (d * d))

    r, j = _linearise(level, px, py, pose)
    cost = total(pose, r)
    n = max(len(r), 1)
    max_xy = MAX_STEP_CELLS * level.res
    for _ in range(iterations):
        h = j.T @ j
        h[np.diag_indices(3)] += H_FLOOR * (1.0 + np.trace(h)) + w
        try:
            step = np.linalg.solve(h, j.T @ r - w * (pose - start))
        except np.linalg.LinAlgError:
            break
        norm = math.hypot(step[0], step[1])
        if norm > max_xy:
            step[:2] *= max_xy / norm
        step[2] = min(max(step[2], -MAX_ROT_STEP), MAX_ROT_STEP)
        for _halving in range(4):
            cand = pose + step
            r2, j2 = _linearise(level, px, py, cand)
            c2 = total(cand, r2)
            if c2 <= cost:
                pose, r, j, cost = cand, r2, j2, c2
                break
            step *= 0.5
        else:
            break
    return pose, j.T @ j, float(r @ r) / n


def covariance(h: np.ndarray, mse: float, n: int) -> np.ndarray:
    """Pose covariance from the Gauss-Newton Hessian: σ² H⁻¹ with σ² the residual variance.

    (hector_mapping hands out the Hessian itself and scales it in the node; the inverse scaled by
    the residual variance is the usual least-squares estimate.)"""
    sigma2 = mse * n / max(n - 3, 1)
    hh = h + np.eye(3) * H_FLOOR
    try:
        cov = np.linalg.inv(hh) * sigma2
    except np.linalg.LinAlgError:
        return np.eye(3) * 1e3
    return 0.5 * (cov + cov.T)


def score(levels: list[GridLevel], pts: np.ndarray, pose: np.ndarray) -> float:
    """Σ M over the scan points at ``pose`` on every level (never-observed cells read 0): how much of
    the scan lands on the map's walls (the coarser levels see a scan near a wall, not only on it)."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    x, y = pose[0] + c * pts[:, 0] - s * pts[:, 1], pose[1] + s * pts[:, 0] + c * pts[:, 1]
    return float(sum(np.nan_to_num(lv.interp(x, y)[0], nan=0.0).sum() for lv in levels))


def presearch(level: GridLevel, pts: np.ndarray, pose: np.ndarray, linear: float, angular: float,
              angular_step: float) -> np.ndarray:
    """Exhaustive search of the window ±``linear`` (steps of one cell of ``level``) × ±``angular``
    around ``pose`` for the largest Σ M: a starting point for Gauss-Newton after a fast turn.
    Ties keep the pose closest to ``pose``."""
    na = int(round(angular / angular_step)) if angular > 0 else 0
    nl = int(round(linear / level.res)) if linear > 0 else 0
    angles = pose[2] + angular_step * np.arange(-na, na + 1)
    offs = level.res * np.arange(-nl, nl + 1)
    c, s = np.cos(angles)[:, None], np.sin(angles)[:, None]
    rx = c * pts[:, 0] - s * pts[:, 1]  # (A, N)
    ry = s * pts[:, 0] + c * pts[:, 1]
    x = pose[0] + offs[None, :, None, None] + rx[:, None, None, :]  # (A, X, 1, N)
    y = pose[1] + offs[None, None, :, None] + ry[:, None, None, :]  # (A, 1, Y, N)
    x, y = np.broadcast_arrays(x, y)
    m, _, _ = level.interp(x.reshape(-1), y.reshape(-1))
    score = np.nan_to_num(m, nan=0.0).reshape(x.shape).sum(axis=-1)  # (A, X, Y); unobserved: 0
    ia, ix, iy = np.meshgrid(np.arange(-na, na + 1), np.arange(-nl, nl + 1), np.arange(-nl, nl + 1),
                             indexing="ij")
    score = score - 1e-6 * (np.abs(ia) + np.abs(ix) + np.abs(iy))
    a, i, k = np.unravel_index(int(np.argmax(score)), score.shape)
    return np.array([pose[0] + offs[i], pose[1] + offs[k], angles[a]])


def match(levels: list[GridLevel], pts: np.ndarray, start: np.ndarray, coarse_iterations: int = 3,
          fine_iterations: int = 5, search_linear: float = 0.0, search_angular: float = 0.0,
          search_angular_step: float = 0.025, prior_w: np.ndarray | None = None
          ) -> tuple[np.ndarray, np.ndarray]:
    """Match on the coarsest level first, then each finer one from the previous result (optionally
    after a ``presearch`` on the coarsest level); the prior (``prior_w``) is centred on ``start``, the
    prediction, on every level.

    ``levels[0]`` is the finest. Returns (pose, 3×3 covariance from the finest level's Hessian)."""
    pose = np.asarray(start, float)
    anchor = pose.copy()
    if search_linear > 0 or search_angular > 0:
        pose = presearch(levels[-1], pts, pose, search_linear, search_angular, search_angular_step)
    h, mse = np.eye(3), 1.0
    for i in range(len(levels) - 1, -1, -1):
        pose, h, mse = gauss_newton(levels[i], pts, pose, fine_iterations if i == 0 else coarse_iterations,
                                    prior_w, anchor)
    pose[2] = math.atan2(math.sin(pose[2]), math.cos(pose[2]))
    return pose, covariance(h, mse, len(pts))
