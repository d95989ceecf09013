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
from master_side.slam.grid import TILE, TILE_BITS, TiledGrid
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

    def fieldset(self, grids: list[TiledGrid], ranges: list[tuple[int, int, int, int]],
                 scratch: bool = False) -> FieldSet:
        """The fields of ``grids[i]`` over tile ranges (tx0, ty0, tx1, ty1), as one FieldSet
        (window border cells score 0, as a window's own field would). ``scratch``: the FieldSet
        lives in buffers the next ``scratch`` call reuses."""
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
            self._build(todo)
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

    def _build(self, todo: dict[bytes, tuple[TiledGrid, int, int, int, int]]) -> None:
        """Compute the field tiles of ``todo`` (key -> grid, tx, ty, ...) into fresh slots."""
        r, m = self.radius, len(todo)
        slots = self._alloc(m)
        items = list(todo.values())
        by_grid: dict[int, list[int]] = {}
        for i, item in enumerate(items):
            by_grid.setdefault(item[3], []).append(i)
        occ = np.empty((m, TILE + 2 * r, TILE + 2 * r), np.float32)  # each tile with its r-cell border
        order: list[int] = []
        for rows in by_grid.values():
            g = items[rows[0]][0]
            t = np.array([items[i][1:3] for i in rows], np.int64)
            tx0, ty0 = t.min(axis=0)  # the tiles' neighbourhood: one more tile around
            tx1, ty1 = t.max(axis=0) + 1
            near = g.slots(int(tx0) - 1, int(ty0) - 1, int(tx1) + 1, int(ty1) + 1)
            nbr = np.stack([near[t[:, 1] - ty0 + dy, t[:, 0] - tx0 + dx] for dy in (0, 1, 2) for dx in (0, 1, 2)], 1)
            at = len(order)
            map_kernels.gather_patches(g.pool.data.reshape(-1), nbr, TILE_BITS, r, occ[at:at + len(rows)])
            order.extend(rows)
        border = np.full(m, r, np.int64)
        map_kernels.tile_fields(occ, np.arange(m), border, border, r, FAR, self.table, COARSE, self.fine, self.coarse,
                                slots[order])
        for key, s in zip(todo, slots.tolist()):
            self.slots[key] = s
        self.built += m

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

