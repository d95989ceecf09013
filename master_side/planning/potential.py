"""Navigation-function potential: a wavefront of navfn's planar-wave (quadratic) cell update.

navfn propagates a potential from a source cell with priority buffers and, per cell, the update from
the two lowest 4-neighbours (one per axis): ``(u - a)^2 + (u - b)^2 = h^2`` (a first-order Eikonal
step; navfn uses a polynomial fit of its root), or ``u = min(a, b) + h`` when ``|a - b| >= h``.
Here the wavefront is updated one turn at a time (a label-correcting "fast iterative method"): every
cell of the front gets its update from the potentials of the previous turn, then every cell whose
potential dropped re-activates the neighbours navfn's push rule would push (``pot > new + h / sqrt 2``),
so the result is the fixed point navfn converges to. With ``heuristic`` (A*) only cells whose
``potential + heuristic`` is within a band above the current minimum are committed, as navfn's
``propNavFnAstar`` threshold blocks do; the rest wait for a later turn.

The turns run in a compiled kernel (``common.jit``), one cell at a time as navfn does, a few hundred
turns per call between deadline checks; ``tests/planning/reference_impl.py`` keeps the numpy version
(whole front per numpy call) and the tests require the same bits from both.

Arrays are flat and padded: ``cost`` has an impassable (inf) ring so neighbours need no bounds checks.
"""

from __future__ import annotations

import math
import time

import numpy as np

from common.jit import kernel
from master_side.planning.errors import PlannerTimeout

INV_SQRT2 = 0.7071067811865476
TURNS_PER_CALL = 512  # wavefront turns between deadline checks


def pad_costs(cell_cost: np.ndarray) -> np.ndarray:
    """(H, W) float cell costs (inf = impassable) -> flat (H+2)*(W+2) array with an inf border."""
    h, w = cell_cost.shape
    out = np.full((h + 2, w + 2), np.inf)
    out[1:-1, 1:-1] = cell_cost
    return out.ravel()


def propagate(
    cost: np.ndarray,
    width: int,
    source: int,
    stop: int = -1,
    *,
    quadratic: bool = True,
    heuristic: np.ndarray | None = None,
    band: float = 0.0,
    margin: float = 0.0,
    rise: float = 0.0,
    max_cycles: int = 1_000_000,
    deadline: float | None = None,
) -> tuple[np.ndarray, int]:
    """Potential from ``source`` over padded flat ``cost`` (row stride ``width``).

    Stops when no cell can still improve, or once ``stop`` has a potential and every pending cell
    would get at least ``pot[stop] + margin`` (``margin`` >= 0). ``rise`` > 0 (the least potential rise per
    4-neighbour step, e.g. the smallest passable cost / sqrt 2) makes that bar local: a pending cell counts
    with its value plus ``rise`` times its grid (L1) distance to ``stop``, a lower bound of what it could
    still bring there, so fronts far from ``stop`` need not catch up first. ``heuristic`` (flat,
    admissible) turns on A* ordering with threshold blocks ``band`` wide. Returns (potential with inf =
    unreached, cycles).
    Raises PlannerTimeout past ``deadline`` (time.monotonic()).
    """
    cost = np.ascontiguousarray(cost, dtype=np.float64)
    n = cost.size
    pot = np.full(n, np.inf)
    pot[source] = 0.0
    mark = np.zeros(n, dtype=np.int64)  # the turn that last queued a cell (dedup)
    front, spare, changed = (np.empty(n, dtype=np.int64) for _ in range(3))
    new = np.empty(n)
    k = 0
    for q in (source - 1, source - width, source + 1, source + width):
        if math.isfinite(cost[q]):
            front[k] = q
            k += 1
    use_heur = heuristic is not None
    heur = np.ascontiguousarray(heuristic, dtype=np.float64) if use_heur else cost[:1]
    cycles, cur_t, done = 0, -math.inf, False
    while not done:
        if deadline is not None and cycles and time.monotonic() > deadline:
            raise PlannerTimeout(f"potential propagation exceeded its time limit after {cycles} cycles")
        k, cycles, cur_t, done, swapped = _turns(
            cost, pot, mark, front, spare, changed, new, k, width, stop, quadratic, use_heur, heur,
            band, margin, rise, cycles, max_cycles, cur_t, TURNS_PER_CALL,
        )
        if swapped:  # the front ended in the other buffer
            front, spare = spare, front
    return pot, cycles


@kernel
def _turns(cost, pot, mark, front, spare, changed, new, k, width, stop, quadratic, use_heur, heur, band,
           margin, rise, cycles, max_cycles, cur_t, budget):
    """Up to ``budget`` wavefront turns on the ``k`` cells in ``front``.

    Returns (front size, cycles, cur_t, done, whether the front now sits in ``spare``).
    """
    cur, nxt = front, spare
    swapped = False
    sr, sc = (stop // width, stop % width) if stop >= 0 else (0, 0)
    for _ in range(budget):
        if k == 0:
            return k, cycles, cur_t, True, swapped
        cycles += 1
        if cycles > max_cycles:
            return k, cycles, cur_t, True, swapped
        kmin = math.inf
        for i in range(k):  # every front cell's update from the last turn's potentials
            c = cur[i]
            a, b = pot[c - 1], pot[c + width]
            x, y = pot[c + 1], pot[c - width]
            a = x if x < a else a  # np.minimum: the lower neighbour along x, then along y
            b = y if y < b else b
            h = cost[c]
            if quadratic:
                lo = b if b < a else a
                dc = abs(a - b)
                if dc > h:  # |a - b| >= h degenerates to lo + h
                    dc = h
                v = ((math.sqrt(2.0 * h * h - dc * dc) + dc) * 0.5) + lo
            else:
                v = (b if b < a else a) + h
            new[i] = v
            if use_heur:
                kmin = min(kmin, v + heur[c])
        m = 0  # the next front: cells left waiting by the A* band come first
        if use_heur:
            cur_t = max(cur_t, kmin + band)
            floor = kmin
            for i in range(k):
                c = cur[i]
                if new[i] + heur[c] > cur_t:
                    new[i] = math.nan  # not committed this turn
                    if mark[c] != cycles:
                        mark[c] = cycles
                        nxt[m] = c
                        m += 1
        if stop >= 0 and pot[stop] < math.inf:
            if not use_heur:
                floor = math.inf
                for i in range(k):
                    v = new[i]
                    if rise > 0.0:
                        c = cur[i]
                        v = v + rise * (abs(c // width - sr) + abs(c % width - sc))
                    floor = min(floor, v)
            if floor >= pot[stop] + margin:
                return k, cycles, cur_t, True, swapped
        nc = 0
        for i in range(k):  # commit the drops (nan, the waiting cells, never compares lower)
            c = cur[i]
            if new[i] < pot[c]:
                pot[c] = new[i]
                changed[nc] = c
                nc += 1
        for j in range(nc):  # navfn's push rule, against the potentials after this turn
            c = changed[j]
            v = pot[c]
            for q in (c - 1, c - width, c + 1, c + width):
                if pot[q] > INV_SQRT2 * cost[q] + v and mark[q] != cycles:
                    mark[q] = cycles
                    nxt[m] = q
                    m += 1
        cur, nxt = nxt, cur
        swapped = not swapped
        k = m
    return k, cycles, cur_t, k == 0, swapped
