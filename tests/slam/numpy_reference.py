"""The numpy code the compiled kernels replaced (master_side/slam/scan_matcher.py, gridslam.py and
grid.py before ``kernels``), kept as the reference the kernels must equal bit for bit."""

from __future__ import annotations

import math

import numpy as np

from master_side.slam.field import COARSE, PAD_C, PAD_F, FieldSet
from master_side.slam.grid import L_FREE, L_MAX, L_MIN, L_OCC, TILE, Window
from master_side.slam.gridslam import Beams
from master_side.slam.scan_matcher import MotionPrior, ScanMatcher, _bilinear_scores, _rotated

MOVES = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
TURNS = np.array([0, 0, 0, 0, 1, 2])  # MOVES' heading: unchanged, +step, -step


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
    rx, ry = _rotated(pts, thetas)  # (P, A, B)
    e = (slice(None), None, None)
    base = None
    for q, p0, o, n in ((ry, poses[:, 1], oy, ny), (rx, poses[:, 0], ox, nx)):  # in place, same rounding
        q += p0[e]
        q /= cell
        q -= o[e]
        np.floor(q, out=q)
        qi = q.astype(np.int64)
        np.clip(qi, -half - 1, (n + half)[e], out=qi)
        qi += pad
        if base is None:
            base = qi * w[e]
        else:
            base += qi
    base += off[e]  # (P, A, B) flat index of each beam at shift 0
    r = np.arange(-half, half + 1)
    tx, ty = np.repeat(r, r.size), np.tile(r, r.size)
    # one shift at a time: small buffers that stay in cache (the sums are those of the full gather);
    # shift (tx, ty) reads flat[idx + tx] with idx = base + ty * w, i.e. the slice flat[tx:] at idx
    scores = np.empty(base.shape[:2] + (r.size**2,), np.float32)
    idx, vals = np.empty_like(base), np.empty(base.shape, np.float32)
    base -= half
    for j, dy in enumerate(r):
        np.add(base, (dy * w)[e], out=idx)
        for i in range(r.size):  # tx = r[i]: flat[half + tx:]
            flat[i:].take(idx, out=vals)
            vals.sum(axis=-1, out=scores[:, :, i * r.size + j])
    return scores, np.column_stack((tx, ty)) * cell


class NumpyMatcher(ScanMatcher):
    """``ScanMatcher`` with the numpy correlative search and hill climb."""

    grid_search = staticmethod(_grid_search)

    def _hill_climb(self, fs: FieldSet, pose: np.ndarray, pose0: np.ndarray, pts: np.ndarray,
                    window: tuple[float, float], prior: MotionPrior | None) -> tuple[np.ndarray, np.ndarray]:
        """gmapping's optimizer: try +-x, +-y, +-theta; halve the steps when nothing improves
        (each particle on its own schedule; the finished ones drop out of the batch)."""
        n, P = len(pts), len(pose)
        lstep, astep = min(self.p.lstep, fs.res) / 2, min(self.p.astep, math.radians(0.25)) / 2
        pose = pose.copy()
        cur = (_bilinear_scores(fs, pose[:, None], pts)[:, 0].sum(axis=-1)
               - self._penalty(pose[:, None], pose0, n, window, prior)[:, 0])
        steps = np.tile(np.array([lstep, lstep, astep]), (P, 1))
        refinements = np.zeros(P, np.int64)
        active = np.arange(P)
        for _ in range(200):
            active = active[refinements[active] <= self.p.iterations]
            if active.size == 0:
                break
            sub = self.sub_prior(prior, active)
            cand = pose[active][:, None, :] + MOVES[None] * steps[active][:, None, :]
            # three headings per particle: rotate the beams once per heading, not once per move
            rx, ry = _rotated(pts, cand[:, 3:, 2])
            rot = (rx.take(TURNS, axis=1), ry.take(TURNS, axis=1))
            sc = (_bilinear_scores(fs, cand, pts, active, rot).sum(axis=-1)
                  - self._penalty(cand, pose0[active], n, window, sub))
            k = sc.argmax(axis=1)
            top = sc[np.arange(active.size), k]
            up = top > cur[active]
            a_up = active[up]
            pose[a_up] = cand[up, k[up]]
            cur[a_up] = top[up]
            a_down = active[~up]
            steps[a_down] /= 2
            refinements[a_down] += 1
        pose[:, 2] = (pose[:, 2] + np.pi) % (2 * np.pi) - np.pi
        return pose, _bilinear_scores(fs, pose[:, None], pts)[:, 0].sum(axis=-1)


def integrate_flips(win: Window, pose: np.ndarray, beams: Beams) -> tuple[np.ndarray, np.ndarray]:
    """``integrate``, also returning the cells whose occupancy (log-odds > 0) changed."""
    ny, nx = win.data.shape
    c, s = math.cos(pose[2]), math.sin(pose[2])
    idx = []
    for pts in (beams.free, beams.hits):
        x = pose[0] + c * pts[:, 0] - s * pts[:, 1]
        y = pose[1] + s * pts[:, 0] + c * pts[:, 1]
        ix = np.floor(x / win.res).astype(np.int64) - win.ix0  # Window.cells
        iy = np.floor(y / win.res).astype(np.int64) - win.iy0
        if len(ix) and (ix.min() < 0 or iy.min() < 0 or ix.max() >= nx or iy.max() >= ny):
            ok = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny)
            ix, iy = ix[ok], iy[ok]
        iy *= nx
        iy += ix
        idx.append(iy)
    mark = np.zeros(ny * nx, np.float32)
    mark[idx[0]] = L_FREE
    mark[idx[1]] = L_OCC  # hits overwrite free marks of the same cell
    cells = np.concatenate(idx)
    flat = win.data.ravel()
    # duplicates in ``cells`` all write the same value: each cell changes once per scan
    old = flat[cells]
    new = old + mark[cells]
    np.clip(new, L_MIN, L_MAX, out=new)
    flat[cells] = new
    return cells, cells[(old > 0) != (new > 0)]


def _flipped_parts(cells: np.ndarray, nx: int, halo: int) -> dict[tuple[int, int], np.ndarray]:
    """(tile row, tile col) -> mask (9,) of the tile parts holding any of the window cells."""
    if cells.size == 0:
        return {}
    r, c = cells // nx, cells % nx
    lr, lc = r % TILE, c % TILE
    ys = (lr < halo, np.ones(r.shape, bool), lr >= TILE - halo)
    xs = (lc < halo, np.ones(r.shape, bool), lc >= TILE - halo)
    mask = np.stack([ys[a] & xs[b] for a in range(3) for b in range(3)], axis=1)
    tid = (r // TILE) * (nx // TILE) + c // TILE
    order = np.argsort(tid, kind="stable")
    tid, mask = tid[order], mask[order]
    starts = np.flatnonzero(np.r_[True, tid[1:] != tid[:-1]])
    any_ = np.logical_or.reduceat(mask, starts, axis=0)
    ntx = nx // TILE
    return {(int(t) // ntx, int(t) % ntx): m for t, m in zip(tid[starts], any_)}


def fill_field(view: np.ndarray, pool: np.ndarray, slots: np.ndarray, pad: int) -> None:
    """``field_cache._fill`` of the tiles pool[slots] before ``map_kernels.fill_field``: write the
    tiles (nty, ntx, t, t) into the padded 2-D view, zero the padding and the border."""
    from numpy.lib.stride_tricks import as_strided

    tiles = pool[slots]
    nty, ntx, t, _ = tiles.shape
    h, w = view.shape
    view[:pad + 1] = 0.0
    view[h - pad - 1:] = 0.0
    view[:, :pad + 1] = 0.0
    view[:, w - pad - 1:] = 0.0
    inner = view[pad:pad + nty * t, pad:pad + ntx * t]
    s0, s1 = inner.strides
    blocks = as_strided(inner, (nty, t, ntx, t), (s0 * t, s0, s1 * t, s1))
    blocks[...] = tiles.transpose(0, 2, 1, 3)
    inner[0, :] = inner[-1, :] = 0.0
    inner[:, 0] = inner[:, -1] = 0.0
