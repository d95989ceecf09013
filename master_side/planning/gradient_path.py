"""Path extraction by gradient descent on a navigation-function potential (navfn ``calcPath``).

Steps of ``step`` cells along the bilinearly interpolated, per-cell normalised gradient (navfn's
``gradCell``: central difference, one-sided next to unreached cells). Where the four interpolation
cells are not all surrounded by reached cells (next to obstacles), where the gradient is flat, or when
the path oscillates, it falls back to stepping to the lowest of the 8 neighbouring cells.

The walk is a compiled kernel (``common.jit``); ``tests/planning/reference_impl.py`` keeps the plain
Python walk it must match.
"""

from __future__ import annotations

import math

import numpy as np

from common.jit import kernel


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
    out = np.empty((max_steps + 1, 2))
    n = _walk(np.ascontiguousarray(pot2d, dtype=np.float64).ravel(), rows, cols, float(start_rc[1]),
              float(start_rc[0]), float(done_below), float(step), bool(grid_only), int(max_steps), out)
    return out[:n].copy() if n > 0 else None


@kernel
def _grad(pot, k, cols):
    """navfn gradCell at flat index k: downhill unit gradient (gx, gy) and whether k and its 8
    neighbours are all reached ('smooth'). Central difference, one-sided next to unreached cells."""
    inf = math.inf
    cv = pot[k]
    if cv == inf:  # also every cell of the padding ring, so the reads below stay in range
        return 0.0, 0.0, False
    up, dn, le, ri = pot[k - cols], pot[k + cols], pot[k - 1], pot[k + 1]
    smooth = max(pot[k - cols - 1], pot[k - cols + 1], pot[k + cols - 1], pot[k + cols + 1],
                 max(up, dn, le, ri)) < inf
    dx = (le - cv if le < inf else 0.0) + (cv - ri if ri < inf else 0.0)
    dy = (up - cv if up < inf else 0.0) + (cv - dn if dn < inf else 0.0)
    n = math.hypot(dx, dy)
    if n == 0.0:
        return 0.0, 0.0, smooth
    return dx / n, dy / n, smooth


@kernel
def _walk(pot, rows, cols, x, y, done_below, step, grid_only, max_steps, out):
    """The descent; fills ``out`` with (col, row) points and returns their count, 0 if stuck."""
    r_end, c_end = rows - 1, cols - 1
    out[0, 0], out[0, 1] = x, y
    for n in range(1, max_steps + 1):
        r, c = int(y + 0.5), int(x + 0.5)
        if not (0 < r < r_end and 0 < c < c_end):
            return 0
        k = r * cols + c
        if pot[k] < done_below:
            return n
        norm = 0.0
        vx = vy = 0.0
        if not grid_only and not (n > 2 and x == out[n - 3, 0] and y == out[n - 3, 1]):
            c0, r0 = int(x), int(y)  # x, y > 0 inside the padded grid, so int() is floor()
            k0 = r0 * cols + c0
            x0, y0, s0 = _grad(pot, k0, cols)
            x1, y1, s1 = _grad(pot, k0 + 1, cols)
            x2, y2, s2 = _grad(pot, k0 + cols, cols)
            x3, y3, s3 = _grad(pot, k0 + cols + 1, cols)
            if s0 and s1 and s2 and s3:
                fx, fy = x - c0, y - r0
                ex, ey = 1 - fx, 1 - fy
                w0, w1, w2, w3 = ex * ey, fx * ey, ex * fy, fx * fy
                vx = w0 * x0 + w1 * x1 + w2 * x2 + w3 * x3
                vy = w0 * y0 + w1 * y1 + w2 * y2 + w3 * y3
                norm = math.hypot(vx, vy)
        if norm > 1e-6:
            x += step * vx / norm
            y += step * vy / norm
        else:  # obstacle nearby, flat gradient or oscillation: steepest 8-neighbour on the grid
            best, bk = pot[k], k
            for dr in (-1, 0, 1):
                for dc in (-1, 0, 1):
                    q = k + dr * cols + dc
                    if q != k and pot[q] < best:
                        best, bk = pot[q], q
            if bk == k:
                return 0
            y, x = float(bk // cols), float(bk % cols)
        out[n, 0], out[n, 1] = x, y
    return 0
