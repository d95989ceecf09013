"""Per-particle log-odds grids as tables of tile slots in one shared, copy-on-write tile pool.

Every grid of a filter indexes the same ``TilePool``: a (capacity, TILE, TILE) array of tiles with a
reference count per slot. A resampled particle copies only its table (and counts one more reference
per tile); a tile is cloned the first time a grid writes to a tile it shares (gmapping shares map
patches through a reference-counted tree the same way). Scans are written straight into the tiles
by one compiled pass (``integrate``), without a dense copy of the grid.
Cell (ix, iy) covers [ix*res, (ix+1)*res) x [iy*res, (iy+1)*res) in the map frame.
"""

from __future__ import annotations

import math

import numpy as np

from common.geometry import Pose2D
from common.messages import Header, OccupancyGrid
from master_side.slam import map_kernels

TILE = 64  # cells per tile side
TILE_BITS = 6  # TILE == 1 << TILE_BITS: tile of a cell index by a shift
L_OCC, L_FREE, L_MIN, L_MAX = 0.9, -0.35, -3.0, 4.0  # log-odds increments and clamps
HALO = 8  # default cells: the border strips of a tile that its neighbours' likelihood fields see
LOG_ODDS = tuple(np.float32(v) for v in (L_FREE, L_OCC, L_MIN, L_MAX))  # the kernels' float32 constants
# Occupancy stamps, shared by every pool (kernels advance it in place): a tile's ``occ[3 * sy + sx]``
# stamps its occupancy (data > 0) in nine parts - sy, sx = 0: the halo rows / columns at the low
# edge, 1: all of them, 2: the halo at the high edge (occ[4] = the whole tile). A stamp changes
# whenever its part's occupancy may have changed; clones keep them, so likelihood fields can be
# cached per occupancy (``field_cache``). 0 = no tile.
_STAMP = np.ones(1, np.int64)


def next_stamp() -> int:
    s = int(_STAMP[0])
    _STAMP[0] += 1
    return s


class TilePool:
    """Tiles (log-odds float32), their occupancy stamps and reference counts; free slots on a stack."""

    def __init__(self, capacity: int = 64):
        self.data = np.zeros((capacity, TILE, TILE), np.float32)
        self.occ = np.zeros((capacity, 9), np.int64)
        self.refs = np.zeros(capacity, np.int64)
        self.mark = np.zeros(capacity * TILE * TILE, np.uint8)  # integration scratch, kept zeroed
        self.parts = np.zeros(capacity, np.int64)  # integration scratch: flipped parts per slot
        self.free = np.arange(capacity - 1, -1, -1, dtype=np.int64)
        self.nfree = capacity

    def reserve(self, n: int) -> None:
        """At least ``n`` free slots (the kernels take slots without growing the pool)."""
        if self.nfree >= n:
            return
        old = len(self.refs)
        extra = max(old, n - self.nfree)
        self.data = np.concatenate((self.data, np.zeros((extra, TILE, TILE), np.float32)))
        self.occ = np.concatenate((self.occ, np.zeros((extra, 9), np.int64)))
        self.refs = np.concatenate((self.refs, np.zeros(extra, np.int64)))
        self.mark = np.concatenate((self.mark, np.zeros(extra * TILE * TILE, np.uint8)))
        self.parts = np.concatenate((self.parts, np.zeros(extra, np.int64)))
        free = np.empty(self.nfree + extra, np.int64)
        free[:extra] = np.arange(old + extra - 1, old - 1, -1)
        free[extra:] = self.free[:self.nfree]
        self.free, self.nfree = free, len(free)

    def take(self) -> int:
        self.reserve(1)
        self.nfree -= 1
        return int(self.free[self.nfree])

    def release(self, slots: np.ndarray) -> None:
        """One reference fewer to each of ``slots`` (distinct); unreferenced slots become free."""
        if not len(slots):
            return
        self.refs[slots] -= 1
        dead = slots[self.refs[slots] == 0]
        if len(self.free) < self.nfree + len(dead):
            self.free = np.concatenate((self.free, np.empty(len(dead), np.int64)))
        self.free[self.nfree:self.nfree + len(dead)] = dead
        self.nfree += len(dead)


class Window:
    """A dense copy of a tile-aligned part of a grid: ``data[row, col]``, row = y."""

    def __init__(self, data: np.ndarray, tx0: int, ty0: int, res: float):
        self.data, self.tx0, self.ty0, self.res = data, tx0, ty0, res
        self.ix0, self.iy0 = tx0 * TILE, ty0 * TILE

    def cells(self, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Integer (col, row) of (N, 2) map-frame points."""
        return (np.floor(pts[..., 0] / self.res).astype(np.int64) - self.ix0,
                np.floor(pts[..., 1] / self.res).astype(np.int64) - self.iy0)


class TiledGrid:
    """A table of pool slots (-1: no tile) over tiles (otx + i, oty + j); grows as scans need."""

    def __init__(self, resolution: float, halo: int = HALO, pool: TilePool | None = None):
        self.res, self.halo = resolution, halo
        self.pool = pool if pool is not None else TilePool()
        self.table = np.full((0, 0), -1, np.int64)
        self.otx = self.oty = 0

    def __del__(self) -> None:
        table = getattr(self, "table", None)
        if table is not None and table.size:
            self.pool.release(table[table >= 0])

    def copy(self) -> TiledGrid:
        """A copy sharing all tiles; either grid clones a shared tile before writing to it."""
        g = TiledGrid.__new__(TiledGrid)
        g.res, g.halo, g.pool, g.otx, g.oty = self.res, self.halo, self.pool, self.otx, self.oty
        g.table = self.table.copy()
        self.pool.refs[g.table[g.table >= 0]] += 1
        return g

    def tile_range(self, x0: float, y0: float, x1: float, y1: float) -> tuple[int, int, int, int]:
        s = self.res * TILE
        return math.floor(x0 / s), math.floor(y0 / s), math.floor(x1 / s) + 1, math.floor(y1 / s) + 1

    def cover(self, tx0: int, ty0: int, tx1: int, ty1: int) -> None:
        """Grow the table to hold tiles [tx0, tx1) x [ty0, ty1) (with room to spare)."""
        nty, ntx = self.table.shape
        if self.table.size and tx0 >= self.otx and ty0 >= self.oty and tx1 <= self.otx + ntx and ty1 <= self.oty + nty:
            return
        if self.table.size:
            tx0, ty0 = min(tx0, self.otx), min(ty0, self.oty)
            tx1, ty1 = max(tx1, self.otx + ntx), max(ty1, self.oty + nty)
        tx0, ty0, tx1, ty1 = tx0 - 4, ty0 - 4, tx1 + 4, ty1 + 4
        table = np.full((ty1 - ty0, tx1 - tx0), -1, np.int64)
        table[self.oty - ty0:self.oty - ty0 + nty, self.otx - tx0:self.otx - tx0 + ntx] = self.table
        self.table, self.otx, self.oty = table, tx0, ty0

    def slots(self, tx0: int, ty0: int, tx1: int, ty1: int) -> np.ndarray:
        """(ty1 - ty0, tx1 - tx0) pool slots of the tiles in the range (-1: no tile)."""
        out = np.full((ty1 - ty0, tx1 - tx0), -1, np.int64)
        nty, ntx = self.table.shape
        a0, b0 = max(tx0, self.otx), max(ty0, self.oty)
        a1, b1 = min(tx1, self.otx + ntx), min(ty1, self.oty + nty)
        if a0 < a1 and b0 < b1:
            out[b0 - ty0:b1 - ty0, a0 - tx0:a1 - tx0] = self.table[b0 - self.oty:b1 - self.oty,
                                                                   a0 - self.otx:a1 - self.otx]
        return out

    def stamps(self, tx0: int, ty0: int, tx1: int, ty1: int) -> np.ndarray:
        """(ty1 - ty0, tx1 - tx0, 9) occupancy stamps of the tiles in the range (0: no tile)."""
        s = self.slots(tx0, ty0, tx1, ty1)
        out = self.pool.occ[s]
        out[s < 0] = 0
        return out

    def integrate(self, rng: tuple[int, int, int, int], x: float, y: float, theta: float,
                  free: np.ndarray, hits: np.ndarray) -> int:
        """Add a scan taken at pose (x, y, theta) with sensor-frame points ``free`` (F, 2) (each cell
        gains L_FREE) and ``hits`` (H, 2) (L_OCC instead), each cell once, clamped; points off the
        tile range ``rng`` are dropped. Returns the number of cells whose occupancy changed."""
        tx0, ty0, tx1, ty1 = rng
        self.cover(tx0, ty0, tx1, ty1)
        p = self.pool
        p.reserve((tx1 - tx0) * (ty1 - ty0))
        p.nfree, flips = map_kernels.integrate_tiles(
            p.data.reshape(-1), p.occ, p.refs, p.free, p.nfree, p.mark, p.parts, self.table, self.otx, self.oty,
            tx0, ty0, tx1, ty1, TILE_BITS, self.halo, self.res, x, y, math.cos(theta), math.sin(theta), free, hits,
            _STAMP, *LOG_ODDS)
        return flips

    def window(self, x0: float, y0: float, x1: float, y1: float) -> Window:
        """Dense log-odds copy covering the metric box (tile aligned)."""
        tx0, ty0, tx1, ty1 = self.tile_range(x0, y0, x1, y1)
        return self._window(tx0, ty0, tx1, ty1)

    def _window(self, tx0: int, ty0: int, tx1: int, ty1: int) -> Window:
        s = self.slots(tx0, ty0, tx1, ty1)
        blocks = self.pool.data[np.maximum(s, 0)]
        blocks[s < 0] = 0.0
        data = np.ascontiguousarray(blocks.transpose(0, 2, 1, 3).reshape(s.shape[0] * TILE, s.shape[1] * TILE))
        return Window(data, tx0, ty0, self.res)

    def store(self, win: Window, touched: np.ndarray, flipped: np.ndarray | None = None) -> None:
        """Write back the tiles of ``win`` holding any of the ``touched`` flat cell indices;
        ``flipped``: the cells whose occupancy changed (None: any may have)."""
        ny, nx = win.data.shape
        ntx, nty = nx // TILE, ny // TILE
        tiles, parts = map_kernels.tile_parts(touched, touched[:0] if flipped is None else flipped, nx, ntx, nty,
                                              TILE, self.halo)
        self.cover(win.tx0, win.ty0, win.tx0 + ntx, win.ty0 + nty)
        p = self.pool
        for k in np.flatnonzero(tiles).tolist():
            j, i = divmod(k, ntx)
            r, c = win.ty0 + j - self.oty, win.tx0 + i - self.otx
            s = int(self.table[r, c])
            if s < 0:
                new = p.take()
                p.occ[new] = next_stamp()
            elif p.refs[s] > 1:
                new = p.take()
                p.occ[new] = p.occ[s]
                p.refs[s] -= 1
            else:
                new = s
            p.refs[new] = 1
            self.table[r, c] = new
            p.data[new] = win.data[j * TILE:(j + 1) * TILE, i * TILE:(i + 1) * TILE]
            if s >= 0 and (flipped is None or parts[k].any()):
                p.occ[new, np.ones(9, bool) if flipped is None else parts[k]] = next_stamp()

    def extent(self) -> tuple[int, int, int, int]:
        """Tile index range (tx0, ty0, tx1, ty1) holding data."""
        j, i = np.nonzero(self.table >= 0)
        if not len(j):
            return 0, 0, 1, 1
        return (self.otx + int(i.min()), self.oty + int(j.min()), self.otx + int(i.max()) + 1,
                self.oty + int(j.max()) + 1)

    def to_occupancy_grid(self, bounds: tuple[float, float, float, float] | None = None, stamp: float = 0.0,
                          frame_id: str = "map", occ_thresh: float = 0.25) -> OccupancyGrid:
        """ROS grid: -1 unknown, 0 free, 100 occupied (p > occ_thresh); covers data ∪ ``bounds``."""
        tx0, ty0, tx1, ty1 = self.extent()
        if bounds is not None:
            b = self.tile_range(*bounds)
            tx0, ty0, tx1, ty1 = min(tx0, b[0]), min(ty0, b[1]), max(tx1, b[2]), max(ty1, b[3])
        win = self._window(tx0, ty0, tx1, ty1)
        known = win.data != 0.0  # cells never observed are 0, as are those of absent tiles
        thr = math.log(occ_thresh / (1.0 - occ_thresh))
        data = np.full(win.data.shape, -1, np.int8)
        data[known] = 0
        data[known & (win.data > max(thr, 0.0))] = 100
        s = self.res * TILE
        return OccupancyGrid(Header(stamp, frame_id), self.res, Pose2D(tx0 * s, ty0 * s, 0.0), data)

    def memory_bytes(self) -> int:
        return int((self.table >= 0).sum()) * TILE * TILE * 4


def unique_tile_bytes(grids: list[TiledGrid]) -> int:
    """Memory of the tiles of several grids counting shared tiles once."""
    seen = {(id(g.pool), s) for g in grids for s in g.table[g.table >= 0].tolist()}
    return len(seen) * TILE * TILE * 4
