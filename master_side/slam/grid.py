"""Per-particle log-odds grid as a dict of square tiles shared copy-on-write between particles.

A resampled particle copies only the dict (tile references); a tile is cloned the first time a
particle writes to it (gmapping shares map patches through a reference-counted tree the same way).
Cell (ix, iy) covers [ix*res, (ix+1)*res) x [iy*res, (iy+1)*res) in the map frame.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from common.geometry import Pose2D
from common.messages import Header, OccupancyGrid
from master_side.slam import map_kernels

TILE = 64  # cells per tile side
TILE_BITS = 6  # TILE == 1 << TILE_BITS: tile of a (non-negative) cell index by a shift
L_OCC, L_FREE, L_MIN, L_MAX = 0.9, -0.35, -3.0, 4.0  # log-odds increments and clamps


_STAMPS = itertools.count(1)
HALO = 8  # default cells: the border strips of a tile that its neighbours' likelihood fields see
_NEW = np.zeros(9, np.int64)


class _Tile:
    """``occ[3 * sy + sx]``: stamps of the tile's occupancy (data > 0) in nine parts — sy, sx = 0:
    the HALO rows / columns at the low edge, 1: all of them, 2: the HALO at the high edge (occ[4] =
    the whole tile). A stamp changes whenever its part's occupancy may have changed; copies keep
    them, so likelihood fields can be cached per occupancy (``field_cache``)."""

    __slots__ = ("data", "owner", "occ")

    def __init__(self, data: np.ndarray, owner: object, occ: np.ndarray | None = None):
        self.data, self.owner = data, owner
        self.occ = np.full(9, next(_STAMPS), np.int64) if occ is None else occ


class Window:
    """A dense copy of a tile-aligned part of a grid: ``data[row, col]``, row = y."""

    def __init__(self, data: np.ndarray, tx0: int, ty0: int, res: float):
        self.data, self.tx0, self.ty0, self.res = data, tx0, ty0, res
        self.ix0, self.iy0 = tx0 * TILE, ty0 * TILE
        self.seen: tuple | None = None  # (tile range, tile objects copied in), for ``TiledGrid.window``

    def cells(self, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Integer (col, row) of (N, 2) map-frame points."""
        return (np.floor(pts[..., 0] / self.res).astype(np.int64) - self.ix0,
                np.floor(pts[..., 1] / self.res).astype(np.int64) - self.iy0)


class TiledGrid:
    def __init__(self, resolution: float, halo: int = HALO):
        self.res, self.halo = resolution, halo
        self.tiles: dict[tuple[int, int], _Tile] = {}
        self.token = object()

    def copy(self) -> TiledGrid:
        """A copy sharing all tiles; both grids clone a tile before their next write to it."""
        g = TiledGrid.__new__(TiledGrid)
        g.res, g.halo, g.tiles, g.token = self.res, self.halo, dict(self.tiles), object()
        self.token = object()
        return g

    def tile_range(self, x0: float, y0: float, x1: float, y1: float) -> tuple[int, int, int, int]:
        s = self.res * TILE
        return math.floor(x0 / s), math.floor(y0 / s), math.floor(x1 / s) + 1, math.floor(y1 / s) + 1

    def window(self, x0: float, y0: float, x1: float, y1: float, out: np.ndarray | None = None,
               seen: tuple | None = None) -> Window:
        """Dense log-odds copy covering the metric box (tile aligned). ``out``: a flat float32 buffer
        to hold it if large enough (the window's data is then a view of it). ``seen``: the ``seen``
        of the window ``out`` held last; tiles that are the same objects as then are not copied
        again (a tile changes in place only through ``store`` of its owner's window, with that
        window's content, and each buffer is refilled at every update)."""
        rng = tx0, ty0, tx1, ty1 = self.tile_range(x0, y0, x1, y1)
        shape = ((ty1 - ty0) * TILE, (tx1 - tx0) * TILE)
        n = shape[0] * shape[1]
        fresh = out is None
        if fresh:
            data = np.zeros(shape, np.float32)
        else:
            if out.size < n:
                out, seen = np.empty(n + n // 4, np.float32), None
            data = out[:n].reshape(shape)
        old = seen[1] if seen is not None and seen[0] == rng else None
        get = self.tiles.get
        tiles = []
        for ty in range(ty0, ty1):
            r = (ty - ty0) * TILE
            for tx in range(tx0, tx1):
                t = get((tx, ty))
                if old is not None and old[len(tiles)] is t:
                    tiles.append(t)
                    continue
                tiles.append(t)
                c = (tx - tx0) * TILE
                if t is not None:
                    data[r:r + TILE, c:c + TILE] = t.data
                elif not fresh:
                    data[r:r + TILE, c:c + TILE] = 0.0
        win = Window(data, tx0, ty0, self.res)
        win.seen = (rng, tiles)
        return win

    def store(self, win: Window, touched: np.ndarray, flipped: np.ndarray | None = None) -> None:
        """Write back the tiles of ``win`` holding any of the ``touched`` flat cell indices;
        ``flipped``: the cells whose occupancy changed (None: any may have)."""
        ny, nx = win.data.shape
        ntx = nx // TILE
        tiles, parts = map_kernels.tile_parts(touched, touched[:0] if flipped is None else flipped, nx, ntx, ny // TILE,
                                          TILE, self.halo)
        if flipped is None:
            parts = None
        else:
            changed = parts.any(axis=1).tolist()
        seen = win.seen[1] if win.seen is not None else None
        for k in np.flatnonzero(tiles).tolist():
            j, i = divmod(k, ntx)
            key = (win.tx0 + i, win.ty0 + j)
            block = win.data[j * TILE:(j + 1) * TILE, i * TILE:(i + 1) * TILE]
            t = self.tiles.get(key)
            if t is None:
                t = self.tiles[key] = _Tile(block.copy(), self.token)
            else:
                occ = t.occ
                if parts is None:
                    occ = np.full(9, next(_STAMPS), np.int64)
                elif changed[k]:
                    occ = occ.copy()
                    occ[parts[k]] = next(_STAMPS)
                if t.owner is self.token:
                    t.data[...] = block
                    t.occ = occ
                else:
                    t = self.tiles[key] = _Tile(block.copy(), self.token, occ)
            if seen is not None:
                seen[k] = t  # the window's block now holds this tile's data

    def stamps(self, tx0: int, ty0: int, tx1: int, ty1: int) -> np.ndarray:
        """(ty1 - ty0, tx1 - tx0, 9) occupancy stamps of the tiles in the range (0: no tile)."""
        get, zero = self.tiles.get, _NEW
        return np.array([[t.occ if (t := get((tx, ty))) is not None else zero for tx in range(tx0, tx1)]
                         for ty in range(ty0, ty1)], np.int64)

    def extent(self) -> tuple[int, int, int, int]:
        """Tile index range (tx0, ty0, tx1, ty1) holding data."""
        if not self.tiles:
            return 0, 0, 1, 1
        k = np.array(list(self.tiles))
        return int(k[:, 0].min()), int(k[:, 1].min()), int(k[:, 0].max()) + 1, int(k[:, 1].max()) + 1

    def to_occupancy_grid(self, bounds: tuple[float, float, float, float] | None = None, stamp: float = 0.0,
                          frame_id: str = "map", occ_thresh: float = 0.25) -> OccupancyGrid:
        """ROS grid: -1 unknown, 0 free, 100 occupied (p > occ_thresh); covers data ∪ ``bounds``."""
        tx0, ty0, tx1, ty1 = self.extent()
        if bounds is not None:
            b = self.tile_range(*bounds)
            tx0, ty0, tx1, ty1 = min(tx0, b[0]), min(ty0, b[1]), max(tx1, b[2]), max(ty1, b[3])
        s = self.res * TILE
        win = self.window(tx0 * s, ty0 * s, (tx1 - 1) * s, (ty1 - 1) * s)
        known = np.zeros(win.data.shape, bool)
        for (tx, ty), t in self.tiles.items():
            if tx0 <= tx < tx1 and ty0 <= ty < ty1:
                r, c = (ty - ty0) * TILE, (tx - tx0) * TILE
                known[r:r + TILE, c:c + TILE] = t.data != 0.0
        thr = math.log(occ_thresh / (1.0 - occ_thresh))
        data = np.full(win.data.shape, -1, np.int8)
        data[known] = 0
        data[known & (win.data > max(thr, 0.0))] = 100
        return OccupancyGrid(Header(stamp, frame_id), self.res, Pose2D(tx0 * s, ty0 * s, 0.0), data)

    def memory_bytes(self) -> int:
        return sum(t.data.nbytes for t in self.tiles.values())


def unique_tile_bytes(grids: list[TiledGrid]) -> int:
    """Memory of the tiles of several grids counting shared tiles once."""
    seen: dict[int, int] = {}
    for g in grids:
        for t in g.tiles.values():
            seen[id(t)] = t.data.nbytes
    return sum(seen.values())
