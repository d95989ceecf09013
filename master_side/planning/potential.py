"""Navigation-function potential: a wavefront of navfn's planar-wave (quadratic) cell update.

navfn propagates a potential from a source cell with priority buffers and, per cell, the update from
the two lowest 4-neighbours (one per axis): ``(u - a)^2 + (u - b)^2 = h^2`` (a first-order Eikonal
step; navfn uses a polynomial fit of its root), or ``u = min(a, b) + h`` when ``|a - b| >= h``.
Here the whole wavefront is updated at once with numpy (a label-correcting "fast iterative method"):
every cell whose potential dropped re-activates its neighbours, exactly navfn's push rule, so the
result is the fixed point navfn converges to, and a Python loop turn costs the same for 10 or 2000
cells. With ``heuristic`` (A*) only cells whose ``potential + heuristic`` is within a band above the
current minimum are committed, as navfn's ``propNavFnAstar`` threshold blocks do.

Arrays are flat and padded: ``cost`` has an impassable (inf) ring so neighbours need no bounds checks.
A loop turn is a fixed, short list of numpy calls (the per-cell terms ``2 h^2`` and ``h / sqrt 2`` are
computed once per call), since at a few hundred wavefront cells the call count, not the cell count,
sets the time.
"""

from __future__ import annotations

import time

import numpy as np

from master_side.planning.errors import PlannerTimeout

INV_SQRT2 = 0.7071067811865476


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
    n = cost.size
    pot = np.full(n, np.inf)
    pot[source] = 0.0
    stamp = np.empty(n, dtype=np.intp)  # dedup stamps: only read where just written
    ramp = np.arange(min(4 * n + 4, 1 << 14), dtype=np.intp)  # sliced, grown on demand
    h2 = 2.0 * cost * cost  # the quadratic update's 2 h^2, per cell
    push = INV_SQRT2 * cost  # the push rule's least rise h / sqrt 2 (inf cost never passes)
    offs = np.array([-1, -width, 1, width, 0], dtype=np.intp)[:, None]  # 4-neighbours, then the cell
    active = source + offs[:4, 0]
    active = active[np.isfinite(cost[active])]
    use_stop = stop >= 0
    cur_t = -np.inf
    cycles = 0
    minimum, subtract = np.minimum, np.subtract
    while active.size:
        cycles += 1
        if cycles > max_cycles:
            break
        if deadline is not None and (cycles & 31) == 0 and time.monotonic() > deadline:
            raise PlannerTimeout(f"potential propagation exceeded its time limit after {cycles} cycles")
        idx = active + offs  # (5, k): left, down, right, up, the cell
        v = pot[idx]
        ab = minimum(v[:2], v[2:4])  # the lower neighbour along x (row 0) and along y (row 1)
        a, b, old = ab[0], ab[1], v[4]
        if quadratic:
            lo = minimum(a, b)
            dc = subtract(a, b, a)
            np.abs(dc, dc)
            minimum(dc, cost[active], out=dc)  # |a - b| >= h degenerates to lo + h
            new = subtract(h2[active], np.multiply(dc, dc, b), b)
            np.sqrt(new, new)
            new += dc
            new *= 0.5
            new += lo
        else:
            new = minimum(a, b, out=a)
            new += cost[active]
        if heuristic is not None:
            key = new + heuristic[active]
            kmin = key.min()
            cur_t = max(cur_t, kmin + band)
            sel = key <= cur_t
            waiting = active[~sel]
            active, new, idx, old = active[sel], new[sel], idx.compress(sel, 1), old[sel]
            floor = kmin
        else:
            waiting = None
            floor = None
        if use_stop:
            ps = pot[stop]
            if ps < np.inf:
                # A pending update of ``stop`` itself is below pot[stop] (so below the bar): no need to
                # look for it separately.
                if floor is None:
                    floor = _floor(new, active, stop, width, rise) if new.size else np.inf
                if floor >= ps + margin:
                    break
        better = new < old
        nb = idx.compress(better, 1)  # (5, m): the changed cells' neighbours, then the cells
        newv = new[better]
        pot[nb[4]] = newv
        nb = nb[:4]
        keep = pot[nb] > np.add(push[nb], newv)  # navfn's push rule
        cand = nb[keep]
        if waiting is not None and waiting.size:
            cand = np.concatenate((waiting, cand))
        k = cand.size
        if k > ramp.size:
            ramp = np.arange(2 * k, dtype=np.intp)
        r = ramp[:k]
        stamp[cand] = r
        active = cand[stamp[cand] == r]
    return pot, cycles


def _floor(new: np.ndarray, active: np.ndarray, stop: int, width: int, rise: float) -> float:
    """Least potential the pending updates could still bring to ``stop`` (see ``propagate``'s ``rise``)."""
    if rise <= 0.0:
        return float(new.min())
    sr, sc = divmod(stop, width)
    r, c = np.divmod(active, width)
    r -= sr
    c -= sc
    np.abs(r, out=r)
    np.abs(c, out=c)
    r += c
    return float((new + rise * r).min())
