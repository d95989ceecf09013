"""Compiled per-cell loops of the map side (numba, ``common.jit.kernel``): likelihood-field tiles and
the integration of a scan into a log-odds window. Same bits as the numpy code they replaced
(``tests/slam/test_kernels.py`` against ``tests/slam/numpy_reference.py``).
"""

from __future__ import annotations

import math

import numpy as np

from common.jit import kernel


@kernel
def tile_fields(src, which, rows, cols, r, far, table, coarse_n, fine_out, coarse_out, slots):
    """Likelihood fields of m tiles: tile t's occupancy (log-odds > 0) is src[which[t]] over rows
    rows[t] - r .. rows[t] + T + r and the same columns (its field_radius border from the
    neighbours); writes table[squared cell distance to the nearest occupied cell] (``far`` beyond
    r cells) to fine_out[slots[t]] (T, T) and table[min over coarse_n^2 blocks] to coarse_out.
    The distances of ``field.inner_squared_distances``, scattered from the occupied cells (each
    lowers the cells of its disc of radius r)."""
    T = fine_out.shape[1]
    W = T + 2 * r
    span = np.empty(2 * r + 1, np.int64)  # half-width of the disc's row dy
    for dy in range(-r, r + 1):
        span[dy + r] = int(math.floor(math.sqrt(r * r - dy * dy)))
        while (span[dy + r] + 1) ** 2 + dy * dy <= r * r:
            span[dy + r] += 1
    colmin = np.empty(T, np.uint8)
    occ = np.empty(W * W + 1, np.int64)  # flat indices (y W + x) of the occupied cells
    hp = np.empty((T + 4 * r, T + 4 * r), np.uint8)  # cell (oy, ox) of the tile at hp[oy + 2r, ox + 2r]
    for t in range(len(slots)):
        s = src[which[t]]
        y0, x0 = rows[t] - r, cols[t] - r
        hp[:, :] = far
        n = 0  # the occupied cells, listed without a branch per cell
        for y in range(W):
            line = s[y0 + y, x0:x0 + W]
            for x in range(W):
                occ[n] = y * W + x
                n += line[x] > 0.0
        for k in range(n):
            y, x = divmod(occ[k], W)
            for dy in range(-r, r + 1):
                row = hp[y + r + dy]
                q0 = dy * dy
                for dx in range(-span[dy + r], span[dy + r] + 1):
                    q = q0 + dx * dx
                    if q < row[x + r + dx]:
                        row[x + r + dx] = q
        f = fine_out[slots[t]]
        for y in range(T):
            hy = hp[y + 2 * r]
            fy = f[y]
            for x in range(T):
                fy[x] = table[hy[x + 2 * r]]
        c = coarse_out[slots[t]]
        for cy in range(T // coarse_n):  # min over the block's rows (contiguous), then its columns
            colmin[:] = far
            for y in range(cy * coarse_n + 2 * r, (cy + 1) * coarse_n + 2 * r):
                hy = hp[y]
                for x in range(T):
                    colmin[x] = min(colmin[x], hy[x + 2 * r])
            for cx in range(T // coarse_n):
                m = far
                for x in range(cx * coarse_n, (cx + 1) * coarse_n):
                    m = min(m, colmin[x])
                c[cy, cx] = table[m]


@kernel
def updated_log_odds(old, hit, l_free, l_occ, l_min, l_max):
    """A cell's log-odds after one scan: + l_occ for a hit, else + l_free, clamped to [l_min, l_max]."""
    new = old + (l_occ if hit else l_free)
    return min(max(new, l_min), l_max)


@kernel
def part_bits(lr, lc, tile, halo):
    """The parts of a tile holding its cell (row lr, column lc): bit 3 a + b, a / b = 0 the low halo
    rows / columns, 1 all of them, 2 the high halo (``grid``'s occupancy stamps)."""
    bits = 0
    for a in range(3):
        if (a == 0 and lr >= halo) or (a == 2 and lr < tile - halo):
            continue
        for b in range(3):
            if (b == 0 and lc >= halo) or (b == 2 and lc < tile - halo):
                continue
            bits |= 1 << (3 * a + b)
    return bits


@kernel
def integrate_scan(flat, nx, ny, ix0, iy0, res, x, y, c, s, free, hits, mark, l_free, l_occ, l_min, l_max):
    """Add a scan to the log-odds window ``flat`` (ny * nx): the cells of the free points
    (F, 2) gain l_free, those of the hits (H, 2) l_occ instead, each cell once, clamped to
    [l_min, l_max]; points off the window are dropped. ``mark``: zeroed uint8 scratch of >= ny * nx
    (left zeroed). Returns (touched cells, cells whose occupancy (> 0) changed)."""
    cells = np.empty(free.shape[0] + hits.shape[0], np.int64)
    count = 0
    for kind in range(2):
        pts = free if kind == 0 else hits
        for b in range(pts.shape[0]):
            px, py = pts[b, 0], pts[b, 1]
            ix = int(math.floor((x + c * px - s * py) / res)) - ix0
            iy = int(math.floor((y + s * px + c * py) / res)) - iy0
            if ix < 0 or iy < 0 or ix >= nx or iy >= ny:
                continue
            k = iy * nx + ix
            if mark[k] == 0:
                cells[count] = k
                count += 1
            mark[k] = kind + 1
    flipped = np.empty(count, np.int64)
    nf = 0
    for q in range(count):
        k = cells[q]
        old = flat[k]
        new = updated_log_odds(old, mark[k] == 2, l_free, l_occ, l_min, l_max)
        flat[k] = new
        mark[k] = 0
        if (old > 0) != (new > 0):
            flipped[nf] = k
            nf += 1
    return cells[:count], flipped[:nf]


@kernel
def tile_parts(cells, flipped, nx, ntx, nty, tile, halo):
    """For a window of ntx x nty tiles (nx cells per row): which tiles hold any of ``cells``
    (nty * ntx,) and, per tile, which of its nine parts (low halo / all / high halo rows x the
    same for columns) hold any of ``flipped`` (nty * ntx, 9)."""
    touched = np.zeros(nty * ntx, np.bool_)
    for k in cells:
        r = k // nx
        touched[(r // tile) * ntx + (k - r * nx) // tile] = True
    parts = np.zeros((nty * ntx, 9), np.bool_)
    for k in flipped:
        r, c = k // nx, k % nx
        t = (r // tile) * ntx + c // tile
        bits = part_bits(r % tile, c % tile, tile, halo)
        for q in range(9):
            if bits & (1 << q):
                parts[t, q] = True
    return touched, parts


@kernel
def fill_field(view, pool, slots, pad):
    """Field window ``view`` (nty T + 2 pad, ntx T + 2 pad) from the cached tiles pool[slots]
    (slots: (nty, ntx)) in one pass; the padding and the window's border cells are zeroed (the
    border of a window's own field scores 0). Same values as a gather then a block copy, read once."""
    nty, ntx = slots.shape
    t = pool.shape[1]
    h, w = view.shape
    for j in range(nty):
        for y in range(t):
            row = view[pad + j * t + y]
            for i in range(ntx):
                row[pad + i * t:pad + (i + 1) * t] = pool[slots[j, i], y]
    view[:, :pad + 1] = 0.0
    view[:, w - pad - 1:] = 0.0
    view[:pad + 1, :] = 0.0
    view[h - pad - 1:, :] = 0.0


@kernel
def integrate_tiles(flat, occ, refs, free, nfree, mark, parts, table, otx, oty, tx0, ty0, tx1, ty1, bits, halo,
                    res, x, y, c, s, free_pts, hits, stamp, l_free, l_occ, l_min, l_max):
    """``integrate_scan`` written straight into a grid's tiles: ``flat`` is the pool's tiles
    (slots x T*T), ``table[ty - oty, tx - otx]`` the grid's slot of tile (tx, ty) (-1: none; the
    range [tx0, tx1) x [ty0, ty1) must be inside the table, and ``nfree`` >= its tile count).
    A point's tile is created (zeros, fresh stamps) or cloned if shared (refs > 1) the first time
    it is written; points off the range are dropped. ``mark`` (one byte per pool cell) and
    ``parts`` (per slot) are zeroed scratch, left zeroed. The parts (see ``tile_parts``) of a tile
    holding a flipped cell get one fresh stamp per tile. Returns (nfree, number of flipped cells)."""
    t = 1 << bits
    tt = t * t
    cells = np.empty(free_pts.shape[0] + hits.shape[0], np.int64)
    count = 0
    last_tx, last_ty, last_sl = 0, 0, -1  # the tile of the last point kept (last_sl -1: none yet)
    for kind in range(2):
        pts = free_pts if kind == 0 else hits
        for b in range(pts.shape[0]):
            px, py = pts[b, 0], pts[b, 1]
            ix = int(math.floor((x + c * px - s * py) / res))
            iy = int(math.floor((y + s * px + c * py) / res))
            tx, ty = ix >> bits, iy >> bits
            if last_sl >= 0 and tx == last_tx and ty == last_ty:  # most points: the tile of the one before
                sl = last_sl
            else:
                if tx < tx0 or ty < ty0 or tx >= tx1 or ty >= ty1:
                    continue
                sl = table[ty - oty, tx - otx]
            if sl < 0 or refs[sl] > 1:
                nfree -= 1
                new = free[nfree]
                if sl < 0:
                    flat[new * tt:(new + 1) * tt] = 0.0
                    occ[new, :] = stamp[0]
                    stamp[0] += 1
                else:
                    flat[new * tt:(new + 1) * tt] = flat[sl * tt:(sl + 1) * tt]
                    occ[new, :] = occ[sl, :]
                    refs[sl] -= 1
                refs[new] = 1
                table[ty - oty, tx - otx] = new
                sl = new
            last_tx, last_ty, last_sl = tx, ty, sl
            k = sl * tt + (iy - (ty << bits)) * t + (ix - (tx << bits))
            if mark[k] == 0:
                cells[count] = k
                count += 1
            mark[k] = kind + 1
    changed = np.empty(count, np.int64)  # slots with a flipped cell
    nc = 0
    nflip = 0
    for q in range(count):
        k = cells[q]
        old = flat[k]
        new = updated_log_odds(old, mark[k] == 2, l_free, l_occ, l_min, l_max)
        flat[k] = new
        mark[k] = 0
        if (old > 0) != (new > 0):
            nflip += 1
            sl = k // tt
            loc = k - sl * tt
            if parts[sl] == 0:
                changed[nc] = sl
                nc += 1
            parts[sl] |= part_bits(loc // t, loc % t, t, halo)
    for q in range(nc):
        sl = changed[q]
        st = stamp[0]
        stamp[0] += 1
        for p in range(9):
            if parts[sl] & (1 << p):
                occ[sl, p] = st
        parts[sl] = 0
    return nfree, nflip


@kernel
def gather_patches(flat, nbr, bits, r, out):
    """out[m] (T + 2r, T + 2r): tile nbr[m, 4]'s log-odds with an r-cell border from its eight
    neighbours nbr[m, 3 * (dy + 1) + (dx + 1)] (pool slots of ``flat``, slots x T*T; -1: zeros)."""
    t = 1 << bits
    tt = t * t
    for m in range(nbr.shape[0]):
        o = out[m]
        for dy in range(-1, 2):
            ys = t - r if dy == -1 else 0  # rows of the neighbour that land in the patch
            ye = t if dy == -1 else (t if dy == 0 else r)
            oy = ys + dy * t + r  # patch row of the neighbour's row ys
            for dx in range(-1, 2):
                xs = t - r if dx == -1 else 0
                xe = t if dx == -1 else (t if dx == 0 else r)
                ox = xs + dx * t + r
                sl = nbr[m, 3 * (dy + 1) + (dx + 1)]
                for yy in range(ys, ye):
                    row = o[oy + yy - ys]
                    if sl < 0:
                        row[ox:ox + xe - xs] = 0.0
                    else:
                        base = sl * tt + yy * t
                        row[ox:ox + xe - xs] = flat[base + xs:base + xe]
