"""The straightforward versions of the planners' hot paths, kept to check the fast ones against."""

from __future__ import annotations

import numpy as np

from master_side.planning.local.cost_base import REJECT

INV_SQRT2 = 0.7071067811865476


def propagate_reference(cost, width, source, stop=-1, *, quadratic=True, heuristic=None, band=0.0, margin=0.0,
                        max_cycles=1_000_000):
    """navfn potential wavefront as first written (one numpy pass per wavefront, generic dedup)."""
    n = cost.size
    pot = np.full(n, np.inf)
    pot[source] = 0.0
    stamp = np.zeros(n, dtype=np.int64)
    offs = np.array([-1, 1, -width, width])
    active = source + offs
    active = active[np.isfinite(cost[active])]
    cur_t = -np.inf
    cycles = 0
    kmin = None
    while active.size:
        cycles += 1
        if cycles > max_cycles:
            break
        a = np.minimum(pot[active - 1], pot[active + 1])
        b = np.minimum(pot[active - width], pot[active + width])
        h = cost[active]
        lo = np.minimum(a, b)
        if quadratic:
            dc = np.minimum(np.abs(a - b), h)
            new = lo + 0.5 * (dc + np.sqrt(2.0 * h * h - dc * dc))
        else:
            new = lo + h
        if heuristic is not None:
            key = new + heuristic[active]
            kmin = key.min()
            cur_t = max(cur_t, kmin + band)
            take = key <= cur_t
            waiting = active[~take]
            active, new = active[take], new[take]
        else:
            waiting = active[:0]
        better = new < pot[active]
        if stop >= 0 and np.isfinite(pot[stop]):
            floor = kmin if heuristic is not None else (new.min() if new.size else np.inf)
            if floor >= pot[stop] + margin and not better[active == stop].any():
                break
        changed = active[better]
        newv = new[better]
        pot[changed] = newv
        nb = (changed[:, None] + offs).ravel()
        src = np.repeat(newv, 4)
        keep = pot[nb] > src + INV_SQRT2 * cost[nb]
        idx = np.concatenate((waiting, nb[keep]))
        order = np.arange(idx.size)
        stamp[idx] = order
        active = idx[stamp[idx] == order]
    return pot, cycles


def integrate_reference(start, v, dt):
    """Euler poses (S, T + 1, 3) under robot-frame velocities v (S, T, 3)."""
    s, t = v.shape[:2]
    th = np.empty((s, t + 1))
    th[:, 0] = start[2]
    np.cumsum(v[:, :, 2] * dt, axis=1, out=th[:, 1:])
    th[:, 1:] += start[2]
    c, sn = np.cos(th[:, :-1]), np.sin(th[:, :-1])
    poses = np.empty((s, t + 1, 3))
    poses[:, 0, 0], poses[:, 0, 1] = start[0], start[1]
    np.cumsum((v[:, :, 0] * c - v[:, :, 1] * sn) * dt, axis=1, out=poses[:, 1:, 0])
    np.cumsum((v[:, :, 0] * sn + v[:, :, 1] * c) * dt, axis=1, out=poses[:, 1:, 1])
    poses[:, 1:, 0] += start[0]
    poses[:, 1:, 1] += start[1]
    poses[:, :, 2] = th
    return poses


def map_grid_score_reference(cost, trajs):
    """MapGridCost.score on (S, T, 3) poses point by point."""
    ctx = cost.ctx
    d = cost.distances()
    p = trajs.poses
    pts = p[..., :2] if cost.forward == 0.0 else p[..., :2] + cost.forward * np.stack(
        (np.cos(p[..., 2]), np.sin(p[..., 2])), axis=-1)
    r, c, inside = ctx.cells(pts)
    vals = np.where(inside, d[r, c], np.inf) * ctx.resolution
    last = vals[:, -1]
    off = ~inside.all(axis=1)
    if cost.stop_on_failure:
        bad = ~np.isfinite(vals).all(axis=1)
    else:
        bad = np.zeros(len(last), bool)
        last = np.where(np.isfinite(last), last, ctx.grid.size * ctx.resolution)
    return np.where(off | bad, REJECT, last)
