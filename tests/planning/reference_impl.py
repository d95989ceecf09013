"""The straightforward versions of the planners' hot paths, kept to check the fast ones against."""

from __future__ import annotations

import math

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


def descend_reference(pot2d, start_rc, done_below, *, step=0.5, grid_only=False, max_steps=100_000):
    """navfn calcPath without caches: per step the four cells' gradCell, bilinear interpolation, else the
    lowest 8-neighbour; (N, 2) padded (col, row) points or None."""
    rows, cols = pot2d.shape
    pot = pot2d.ravel()
    inf = math.inf

    def grad(k):
        cv = float(pot[k])
        if cv == inf:
            return 0.0, 0.0, False
        nb = [float(pot[k + d]) for d in (-cols - 1, -cols, -cols + 1, -1, 1, cols - 1, cols, cols + 1)]
        le, ri, up, dn = nb[3], nb[4], nb[1], nb[6]
        dx = (le - cv if le < inf else 0.0) + (cv - ri if ri < inf else 0.0)
        dy = (up - cv if up < inf else 0.0) + (cv - dn if dn < inf else 0.0)
        n = float(np.hypot(dx, dy))  # libm's hypot, as the compiled walk (math.hypot rounds otherwise)
        return (0.0, 0.0, max(nb) < inf) if n == 0.0 else (dx / n, dy / n, max(nb) < inf)

    x, y = float(start_rc[1]), float(start_rc[0])
    out = [(x, y)]
    for _ in range(max_steps):
        r, c = int(y + 0.5), int(x + 0.5)
        if not (0 < r < rows - 1 and 0 < c < cols - 1):
            return None
        k = r * cols + c
        if pot[k] < done_below:
            return np.asarray(out)
        c0, r0 = int(x), int(y)
        vx = vy = 0.0
        if not grid_only and not (len(out) > 2 and out[-1] == out[-3]):
            g = [grad(r0 * cols + c0 + d) for d in (0, 1, cols, cols + 1)]
            if all(s for _, _, s in g):
                fx, fy = x - c0, y - r0
                w = ((1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy)
                vx = w[0] * g[0][0] + w[1] * g[1][0] + w[2] * g[2][0] + w[3] * g[3][0]
                vy = w[0] * g[0][1] + w[1] * g[1][1] + w[2] * g[2][1] + w[3] * g[3][1]
        norm = float(np.hypot(vx, vy))
        if norm > 1e-6:
            x, y = x + step * vx / norm, y + step * vy / norm
        else:
            best, bk = pot[k], k
            for d in (-cols - 1, -cols, -cols + 1, -1, 1, cols - 1, cols, cols + 1):
                if pot[k + d] < best:
                    best, bk = pot[k + d], k + d
            if bk == k:
                return None
            y, x = float(bk // cols), float(bk % cols)
        out.append((x, y))
    return None
