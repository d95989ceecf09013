"""Path extraction by gradient descent on a navigation-function potential (navfn ``calcPath``).

Steps of ``step`` cells along the bilinearly interpolated, per-cell normalised gradient (navfn's
``gradCell``: central difference, one-sided next to unreached cells). Where the four interpolation
cells are not all surrounded by reached cells (next to obstacles), where the gradient is flat, or when
the path oscillates, it falls back to stepping to the lowest of the 8 neighbouring cells.
"""

from __future__ import annotations

import math

import numpy as np


def _gradient_reader(pot, cols: int, cache: dict):
    """navfn gradCell at flat index k: downhill unit gradient (gx, gy) and whether k is 'smooth', kept in
    ``cache`` (look there first).

    Central difference, one-sided next to unreached cells; 'smooth' = k and its 8 neighbours reached.
    ``pot`` reads one flat potential value (e.g. ``ndarray.item``).
    """
    inf = math.inf
    hypot = math.hypot

    def grad(k: int) -> tuple[float, float, bool]:
        cv = pot(k)
        if cv == inf:  # also every cell of the padding ring, so the reads below stay in range
            g = cache[k] = (0.0, 0.0, False)
            return g
        up, dn, le, ri = pot(k - cols), pot(k + cols), pot(k - 1), pot(k + 1)
        smooth = max(pot(k - cols - 1), pot(k - cols + 1), pot(k + cols - 1), pot(k + cols + 1), up, dn, le,
                     ri) < inf
        dx = (le - cv if le < inf else 0.0) + (cv - ri if ri < inf else 0.0)
        dy = (up - cv if up < inf else 0.0) + (cv - dn if dn < inf else 0.0)
        n = hypot(dx, dy)
        g = cache[k] = (dx / n, dy / n, smooth) if n != 0.0 else (0.0, 0.0, smooth)
        return g

    return grad


def descend(
    pot2d: np.ndarray,
    start_rc: tuple[int, int],
    done_below: float,
    *,
    step: float = 0.5,
    grid_only: bool = False,
    max_steps: int = 100_000,
) -> np.ndarray | None:
    """Follow the potential downhill from padded cell ``start_rc`` until a cell with pot < done_below.

    Returns (N, 2) padded grid coordinates (col, row) of the path, or None if it got stuck.
    """
    rows, cols = pot2d.shape
    pot = pot2d.ravel().item  # scalar reads; converting the whole grid costs more than the walk
    cells: dict[int, tuple[float, float, bool]] = {}  # flat index -> its gradient
    grad, cached = _gradient_reader(pot, cols, cells), cells.get
    blocks: dict[int, tuple | None] = {}  # upper-left cell -> its 2 x 2 gradients, None if not smooth

    def block(q: int) -> tuple | None:
        x0, y0, s0 = cached(q) or grad(q)
        x1, y1, s1 = cached(q + 1) or grad(q + 1)
        x2, y2, s2 = cached(q + cols) or grad(q + cols)
        x3, y3, s3 = cached(q + cols + 1) or grad(q + cols + 1)
        blocks[q] = b = (x0, x1, x2, x3, y0, y1, y2, y3) if s0 and s1 and s2 and s3 else None
        return b

    nbrs = [dr * cols + dc for dr in (-1, 0, 1) for dc in (-1, 0, 1) if dr or dc]
    hypot = math.hypot
    r_end, c_end = rows - 1, cols - 1
    x, y = float(start_rc[1]), float(start_rc[0])
    xs, ys = [x], [y]  # path so far (two flat lists convert to an array faster than a list of pairs)
    for n in range(1, max_steps + 1):
        r, c = int(y + 0.5), int(x + 0.5)
        if not (0 < r < r_end and 0 < c < c_end):
            return None
        k = r * cols + c
        if pot(k) < done_below:
            return np.column_stack((xs, ys))
        norm = 0.0
        if not grid_only and not (n > 2 and x == xs[-3] and y == ys[-3]):
            c0, r0 = int(x), int(y)  # x, y > 0 inside the padded grid, so int() is floor()
            k0 = r0 * cols + c0
            b = blocks[k0] if k0 in blocks else block(k0)
            if b is not None:
                x0, x1, x2, x3, y0, y1, y2, y3 = b
                fx, fy = x - c0, y - r0
                ex, ey = 1 - fx, 1 - fy
                w0, w1, w2, w3 = ex * ey, fx * ey, ex * fy, fx * fy
                vx = w0 * x0 + w1 * x1 + w2 * x2 + w3 * x3
                vy = w0 * y0 + w1 * y1 + w2 * y2 + w3 * y3
                norm = hypot(vx, vy)
        if norm > 1e-6:
            x += step * vx / norm
            y += step * vy / norm
        else:  # obstacle nearby, flat gradient or oscillation: steepest 8-neighbour on the grid
            best, bk = pot(k), k
            for d in nbrs:
                q = k + d
                pq = pot(q)
                if pq < best:
                    best, bk = pq, q
            if bk == k:
                return None
            y, x = float(bk // cols), float(bk % cols)
        xs.append(x)
        ys.append(y)
    return None
