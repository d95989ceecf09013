"""Likelihood fields for the scan matcher, one per particle, batched into one flat buffer.

F = exp(-d^2 / (2 match_sigma^2)) with d the distance to the nearest occupied cell, 0 beyond
``field_radius`` cells (squared cell distances are small integers: a uint8 distance transform and a
256-entry table). The coarse level is the max of F over COARSE x COARSE blocks (min of distances).
Fields are padded with zeros so that the searches index them without bounds checks.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from master_side.slam.grid import Window
from master_side.slam.params import GMappingParams

COARSE = 4  # coarse level cell = COARSE fine cells
FAR = 200  # "no occupied cell within the radius" in squared cells (uint8, no overflow when adding)
PAD_F = 8  # zero cells around a fine field (>= 2 * fine search half-width + 1)
PAD_C = 24  # zero cells around a coarse field (>= 2 * coarse search half-width + 1; window <= 2 m)


def squared_distance_field(occ: np.ndarray, radius: int) -> np.ndarray:
    """Squared cell distance to the nearest occupied cell (uint8), FAR beyond ``radius`` cells.

    Works on (..., ny, nx) stacks (the same as ``inner_squared_distances`` of the stack padded with
    ``radius`` free cells: cells beyond the edge are never nearer than FAR).
    """
    pad = [(0, 0)] * (occ.ndim - 2) + [(radius, radius)] * 2
    return inner_squared_distances(np.pad(occ, pad), radius)


def inner_squared_distances(occ: np.ndarray, radius: int) -> np.ndarray:
    """``squared_distance_field`` of the cells ``radius`` or more from the edge of (..., ny, nx)
    stacks: (..., ny - 2 radius, nx - 2 radius).

    Separable (squared distances add): a row pass then a column pass of shifted minima.
    """
    r = radius
    sq = np.arange(r + 1, dtype=np.uint8) ** 2
    f = np.where(occ, np.uint8(0), np.uint8(FAR))
    nx, ny = f.shape[-1] - 2 * r, f.shape[-2] - 2 * r
    g = f[..., r:r + nx].copy()
    tmp = np.empty_like(g)
    for d in range(1, r + 1):
        for lo in (r - d, r + d):
            np.add(f[..., lo:lo + nx], sq[d], out=tmp)
            np.minimum(g, tmp, out=g)
    np.minimum(g, FAR, out=g)
    h = g[..., r:r + ny, :].copy()
    tmp = tmp[..., :ny, :]
    for d in range(1, r + 1):
        for lo in (r - d, r + d):
            np.add(g[..., lo:lo + ny, :], sq[d], out=tmp)
            np.minimum(h, tmp, out=h)
    h[h > r * r] = FAR
    return h


def kernel_table(res: float, p: GMappingParams) -> np.ndarray:
    """(256,) float32 kernel value of a squared cell distance (0 for FAR)."""
    table = np.exp(-np.arange(256) * res**2 / (2 * p.match_sigma**2)).astype(np.float32)
    table[FAR:] = 0.0
    return table


def coarse_of(fine: np.ndarray) -> np.ndarray:
    """Min over COARSE x COARSE blocks of the last two axes (shapes multiples of COARSE)."""
    cols = fine[..., 0::COARSE].copy()
    for i in range(1, COARSE):
        np.minimum(cols, fine[..., i::COARSE], out=cols)
    coarse = cols[..., 0::COARSE, :].copy()
    for i in range(1, COARSE):
        np.minimum(coarse, cols[..., i::COARSE, :], out=coarse)
    return coarse


@dataclass
class Field:
    """One particle's field: zero-padded float32 kernel values, fine and coarse."""

    fine: np.ndarray  # (ny + 2 PAD_F, nx + 2 PAD_F)
    coarse: np.ndarray  # (ny / COARSE + 2 PAD_C, nx / COARSE + 2 PAD_C)
    ix0: int  # map cell of fine[PAD_F, PAD_F]
    iy0: int
    res: float


def field_from_distances(fine_d: np.ndarray, ix0: int, iy0: int, res: float, table: np.ndarray) -> Field:
    """Field of a uint8 squared distance window (borders set to FAR here)."""
    fine_d[0, :] = fine_d[-1, :] = FAR
    fine_d[:, 0] = fine_d[:, -1] = FAR
    coarse_d = coarse_of(fine_d)
    coarse_d[0, :] = coarse_d[-1, :] = FAR
    coarse_d[:, 0] = coarse_d[:, -1] = FAR
    fine = np.zeros((fine_d.shape[0] + 2 * PAD_F, fine_d.shape[1] + 2 * PAD_F), np.float32)
    fine[PAD_F:-PAD_F, PAD_F:-PAD_F] = table[fine_d]
    coarse = np.zeros((coarse_d.shape[0] + 2 * PAD_C, coarse_d.shape[1] + 2 * PAD_C), np.float32)
    coarse[PAD_C:-PAD_C, PAD_C:-PAD_C] = table[coarse_d]
    return Field(fine, coarse, ix0, iy0, res)


def make_field(win: Window, p: GMappingParams) -> Field:
    """The field of a log-odds window (occupied: > 0); blind beyond the window."""
    d = squared_distance_field(win.data > 0.0, p.field_radius)
    return field_from_distances(d, win.ix0, win.iy0, win.res, kernel_table(win.res, p))


class FieldSet:
    """Several fields in two flat buffers with per-field offsets / shapes, for batched lookups."""

    def __init__(self, fields: list[Field]):
        self._layout([f.fine.shape for f in fields], [f.coarse.shape for f in fields],
                     [f.ix0 for f in fields], [f.iy0 for f in fields], fields[0].res)
        self.fine = np.concatenate([f.fine.ravel() for f in fields])
        self.coarse = np.concatenate([f.coarse.ravel() for f in fields])

    def _layout(self, shapes_f, shapes_c, ix0, iy0, res: float) -> None:
        self.res = res
        sf, sc = np.array(shapes_f, np.int64), np.array(shapes_c, np.int64)
        self.w_f, self.w_c = sf[:, 1].copy(), sc[:, 1].copy()
        self.nx_f, self.ny_f = sf[:, 1] - 2 * PAD_F, sf[:, 0] - 2 * PAD_F
        self.nx_c, self.ny_c = sc[:, 1] - 2 * PAD_C, sc[:, 0] - 2 * PAD_C
        self.end_f = np.concatenate(([0], np.cumsum(sf[:, 0] * sf[:, 1])))
        self.end_c = np.concatenate(([0], np.cumsum(sc[:, 0] * sc[:, 1])))
        self.off_f, self.off_c = self.end_f[:-1], self.end_c[:-1]
        self.ix0, self.iy0 = np.array(ix0, np.int64), np.array(iy0, np.int64)
        # per field: ix0, iy0, nx - 2, ny - 2, row length, flat index of fine cell (0, 0)
        self.consts = np.column_stack((self.ix0, self.iy0, self.nx_f - 2, self.ny_f - 2, self.w_f,
                                       PAD_F * self.w_f + PAD_F + self.off_f))

    @classmethod
    def empty(cls, shapes_f, shapes_c, ix0, iy0, res: float,
              scratch: tuple[np.ndarray, np.ndarray] | None = None) -> FieldSet:
        """Uninitialised buffers (fill every field through ``views``); ``scratch``: (fine, coarse)
        float32 buffers to use if large enough (fresh pages cost more than the fill)."""
        fs = cls.__new__(cls)
        fs._layout(shapes_f, shapes_c, ix0, iy0, res)
        nf, nc = int(fs.end_f[-1]), int(fs.end_c[-1])
        if scratch is not None and scratch[0].size >= nf and scratch[1].size >= nc:
            fs.fine, fs.coarse = scratch[0][:nf], scratch[1][:nc]
        else:
            fs.fine, fs.coarse = np.empty(nf, np.float32), np.empty(nc, np.float32)
        return fs

    def views(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        """Padded 2-D (fine, coarse) views of field i."""
        f = self.fine[self.end_f[i]:self.end_f[i + 1]].reshape(-1, self.w_f[i])
        c = self.coarse[self.end_c[i]:self.end_c[i + 1]].reshape(-1, self.w_c[i])
        return f, c

    @staticmethod
    def of(f: Field | FieldSet) -> FieldSet:
        return f if isinstance(f, FieldSet) else FieldSet([f])
