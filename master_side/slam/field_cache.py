"""Likelihood fields built once per change of a map tile's occupancy, shared by all particles.

A tile's field depends only on the occupancy of the tile and of its eight neighbours (the field's
support, ``field_radius`` cells, is smaller than a tile). Tiles carry an occupancy stamp (``grid``)
that copies keep and that changes when a cell of the tile crosses log-odds 0, so the nine stamps
key the field: particles that share a neighbourhood (nearly all of them, for most tiles) share one
field tile, computed once, and a particle's field window is assembled from cached tiles.
"""

from __future__ import annotations

import numpy as np

from master_side.slam import map_kernels
from master_side.slam.field import COARSE, FAR, PAD_C, PAD_F, FieldSet, kernel_table
from master_side.slam.grid import TILE, TiledGrid, Window
from master_side.slam.params import GMappingParams

CT = TILE // COARSE  # coarse cells per tile side
ZERO_KEY = bytes(9 * 8)  # nine empty tiles: slot 0, an all-zero field


class FieldCache:
    def __init__(self, p: GMappingParams, capacity: int = 1024):
        self.radius, self.res = p.field_radius, p.delta
        self.table = kernel_table(p.delta, p)
        self.fine = np.zeros((capacity, TILE, TILE), np.float32)
        self.coarse = np.zeros((capacity, CT, CT), np.float32)
        self.slots: dict[bytes, int] = {ZERO_KEY: 0}
        self.last = np.zeros(capacity, np.int64)  # call in which each slot was last used
        self.free = list(range(capacity - 1, 0, -1))
        self.gen = 0
        self.built = 0  # field tiles computed so far
        self._scratch = (np.empty(0, np.float32), np.empty(0, np.float32))
        r = self.radius  # _patch: (dx, dy, part of the neighbour, where it goes) of the nine tiles
        src = {-1: slice(TILE - r, TILE), 0: slice(0, TILE), 1: slice(0, r)}
        dst = {-1: slice(0, r), 0: slice(r, r + TILE), 1: slice(r + TILE, TILE + 2 * r)}
        self._parts = [(dx, dy, (src[dy], src[dx]), (dst[dy], dst[dx])) for dy in (-1, 0, 1) for dx in (-1, 0, 1)]

    def fieldset(self, grids: list[TiledGrid], ranges: list[tuple[int, int, int, int]],
                 windows: list[Window] | None = None, scratch: bool = False) -> FieldSet:
        """The fields of ``grids[i]`` over tile ranges (tx0, ty0, tx1, ty1), as one FieldSet
        (window border cells score 0, as a window's own field would). ``windows``: the grids'
        log-odds over the same ranges if at hand (faster builds). ``scratch``: the FieldSet lives
        in buffers the next ``scratch`` call reuses."""
        self.gen += 1
        keys, where = [], []  # per grid: (tiles, 9) stamps keying each tile's field; (grid, tx0, ty0, ntx)
        for n, (g, (tx0, ty0, tx1, ty1)) in enumerate(zip(grids, ranges)):
            if g.halo < self.radius:
                raise ValueError(f"the grid's halo ({g.halo} cells) is narrower than field_radius")
            s = g.stamps(tx0 - 1, ty0 - 1, tx1 + 1, ty1 + 1)
            nty, ntx = ty1 - ty0, tx1 - tx0
            # neighbour (dy, dx) of a tile contributes its part facing the tile: its high strip
            # for a neighbour below (dy = 0), all of it (dy = 1), its low strip above (dy = 2)
            keys.append(np.stack([s[dy:dy + nty, dx:dx + ntx, 3 * (2 - dy) + (2 - dx)]
                                  for dy in range(3) for dx in range(3)], axis=-1).reshape(-1, 9))
            where.append((n, tx0, ty0, ntx))
        # the distinct keys (particles share most tiles), looked up once each
        flat = np.ascontiguousarray(np.concatenate(keys)).view(np.dtype((np.void, 72))).ravel()
        uniq, first, inverse = np.unique(flat, return_index=True, return_inverse=True)
        ends = np.cumsum([len(k) for k in keys])
        ukeys = uniq.tolist()
        get = self.slots.get
        slot_of = np.array([get(key, -1) for key in ukeys], np.int64)
        self.last[slot_of[slot_of >= 0]] = self.gen  # before _build: its eviction keeps the fields used here
        missing = np.flatnonzero(slot_of < 0)
        if len(missing):
            n_of = np.searchsorted(ends, first[missing], side="right")  # grid of each key's first tile
            k_of = first[missing] - np.concatenate(([0], ends))[n_of]  # and that tile's index in its range
            todo = {}
            for j, n, k in zip(missing.tolist(), n_of.tolist(), k_of.tolist()):
                _, tx0, ty0, ntx = where[n]
                todo[ukeys[j]] = (grids[n], tx0 + k % ntx, ty0 + k // ntx, n, j)
            self._build(todo, ranges, windows)
            for key, item in todo.items():
                slot_of[item[4]] = self.slots[key]
        slots = slot_of[inverse.reshape(-1)]
        shapes_f, shapes_c, ix0, iy0, slot_arrays = [], [], [], [], []
        for (tx0, ty0, tx1, ty1), end, k in zip(ranges, ends.tolist(), keys):
            nty, ntx = ty1 - ty0, tx1 - tx0
            slot_arrays.append(slots[end - len(k):end].reshape(nty, ntx))
            shapes_f.append((nty * TILE + 2 * PAD_F, ntx * TILE + 2 * PAD_F))
            shapes_c.append((nty * CT + 2 * PAD_C, ntx * CT + 2 * PAD_C))
            ix0.append(tx0 * TILE)
            iy0.append(ty0 * TILE)
        fs = FieldSet.empty(shapes_f, shapes_c, ix0, iy0, self.res, self._scratch if scratch else None)
        if scratch and fs.fine.base is not self._scratch[0]:
            self._scratch = (np.empty(int(fs.fine.size * 1.25), np.float32),
                             np.empty(int(fs.coarse.size * 1.25), np.float32))
            fs = FieldSet.empty(shapes_f, shapes_c, ix0, iy0, self.res, self._scratch)
        for i, sl in enumerate(slot_arrays):
            f, c = fs.views(i)
            map_kernels.fill_field(f, self.fine, sl, PAD_F)
            map_kernels.fill_field(c, self.coarse, sl, PAD_C)
        return fs

    def _build(self, todo: dict[bytes, tuple[TiledGrid, int, int, int, int]],
               ranges: list[tuple[int, int, int, int]], windows: list[Window] | None) -> None:
        r, m = self.radius, len(todo)
        slots = self._alloc(m)
        inner: dict[int, list[int]] = {}  # window -> tiles off the window's edge: read from the window
        patched = []  # the others: their neighbourhood copied from the grid's tiles
        items = list(todo.values())
        for i, (_, tx, ty, n, _) in enumerate(items):
            tx0, ty0, tx1, ty1 = ranges[n]
            if windows is not None and tx0 < tx < tx1 - 1 and ty0 < ty < ty1 - 1:
                inner.setdefault(n, []).append(i)
            else:
                patched.append(i)
        args = (r, FAR, self.table, COARSE, self.fine, self.coarse)
        if patched:
            occ = np.empty((len(patched), TILE + 2 * r, TILE + 2 * r), np.float32)
            for k, i in enumerate(patched):
                g, tx, ty, _, _ = items[i]
                self._patch(occ[k], g, tx, ty)
            at = np.full(len(patched), r, np.int64)
            map_kernels.tile_fields(occ, np.arange(len(patched)), at, at, *args, slots[patched])
        for n, rows in inner.items():
            tx0, ty0 = ranges[n][:2]
            tiles = np.array([items[i][1:3] for i in rows], np.int64)
            map_kernels.tile_fields(windows[n].data[None], np.zeros(len(rows), np.int64), (tiles[:, 1] - ty0) * TILE,
                                (tiles[:, 0] - tx0) * TILE, *args, slots[rows])
        for key, s in zip(todo, slots.tolist()):
            self.slots[key] = s
        self.built += m

    def _patch(self, out: np.ndarray, g: TiledGrid, tx: int, ty: int) -> None:
        """Log-odds of tile (tx, ty) with a field_radius border from its neighbours (0: no tile)."""
        get = g.tiles.get
        for dx, dy, src, dst in self._parts:
            t = get((tx + dx, ty + dy))
            if t is None:
                out[dst] = 0.0
            else:
                out[dst] = t.data[src]

    def _alloc(self, m: int) -> np.ndarray:
        if len(self.free) < m:  # forget the fields not used by this call
            last, gen = self.last.tolist(), self.gen
            stale = {k: s for k, s in self.slots.items() if s and last[s] < gen}
            for k, s in stale.items():
                del self.slots[k]
                self.free.append(s)
        if len(self.free) < m:  # grow
            n = len(self.fine)
            extra = max(n, m)
            self.fine = np.concatenate((self.fine, np.zeros((extra, TILE, TILE), np.float32)))
            self.coarse = np.concatenate((self.coarse, np.zeros((extra, CT, CT), np.float32)))
            self.last = np.concatenate((self.last, np.zeros(extra, np.int64)))
            self.free.extend(range(n + extra - 1, n - 1, -1))
        out = np.array(self.free[-m:], np.int64)
        del self.free[-m:]
        self.last[out] = self.gen
        return out

