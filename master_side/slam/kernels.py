"""Compiled per-beam / per-cell loops of the gmapping-style filter (numba, ``common.jit.kernel``).

Each kernel gives the bits of the numpy code it replaced (``tests/slam/test_kernels.py`` compares
them with numpy references): the same float64 / float32 operations in the same order, and float32
sums over beams in numpy's pairwise order (``pairwise_sum``), so maps and trajectories do not change.
"""

from __future__ import annotations

import math

import numpy as np

from common.jit import kernel

F32_ONE = np.float32(1.0)
TWO_PI = 2 * math.pi


@kernel
def _block(v, lo, n):
    """numpy's pairwise_sum for n <= 128: eight accumulators (n < 8: one), then the rest."""
    if n < 8:
        res = np.float32(0.0)
        for i in range(lo, lo + n):
            res += v[i]
        return res
    r0, r1, r2, r3 = v[lo], v[lo + 1], v[lo + 2], v[lo + 3]
    r4, r5, r6, r7 = v[lo + 4], v[lo + 5], v[lo + 6], v[lo + 7]
    i = lo + 8
    m = lo + n - n % 8
    while i < m:
        r0 += v[i]
        r1 += v[i + 1]
        r2 += v[i + 2]
        r3 += v[i + 3]
        r4 += v[i + 4]
        r5 += v[i + 5]
        r6 += v[i + 6]
        r7 += v[i + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < lo + n:
        res += v[i]
        i += 1
    return res


# numpy halves a longer row (the first half a multiple of 8) recursively; numba's cache cannot
# reload self-recursive functions (a segfault), so the levels are spelt out: _pwK takes n <= CAPS[K]
@kernel
def _pw1(v, lo, n):
    if n <= 128:
        return _block(v, lo, n)
    h = n // 2 - (n // 2) % 8
    return _block(v, lo, h) + _block(v, lo + h, n - h)


@kernel
def _pw2(v, lo, n):
    if n <= 128:
        return _block(v, lo, n)
    h = n // 2 - (n // 2) % 8
    return _pw1(v, lo, h) + _pw1(v, lo + h, n - h)


@kernel
def _pw3(v, lo, n):
    if n <= 128:
        return _block(v, lo, n)
    h = n // 2 - (n // 2) % 8
    return _pw2(v, lo, h) + _pw2(v, lo + h, n - h)


@kernel
def _pw4(v, lo, n):
    if n <= 128:
        return _block(v, lo, n)
    h = n // 2 - (n // 2) % 8
    return _pw3(v, lo, h) + _pw3(v, lo + h, n - h)


@kernel
def _pw5(v, lo, n):
    if n <= 128:
        return _block(v, lo, n)
    h = n // 2 - (n // 2) % 8
    return _pw4(v, lo, h) + _pw4(v, lo + h, n - h)


MAX_SUM = 3848  # the longest row _pw5 sums as numpy does


@kernel
def pairwise_sum(v, lo, n):
    """float32 sum of v[lo:lo + n] in numpy's order (``np.add.reduce`` of a contiguous row)."""
    if n > MAX_SUM:
        raise ValueError("pairwise_sum: row too long")
    return _pw5(v, lo, n)


@kernel
def bilinear_sum(fine, consts, x, y, c, s, pts, res, vals):
    """Score (float32) of pose (x, y) with heading cos / sin (c, s) in the field of ``consts``
    (ix0, iy0, nx - 2, ny - 2, row length, flat index of cell (0, 0)): the sum over beams of the
    bilinearly interpolated field. ``vals``: (B,) float32 scratch."""
    ix0, iy0 = float(consts[0]), float(consts[1])
    nxm2, nym2, w, base = consts[2], consts[3], consts[4], consts[5]
    n = pts.shape[0]
    for b in range(n):
        px, py = pts[b, 0], pts[b, 1]
        u = c * px - s * py
        v = s * px + c * py
        u += x
        u /= res
        u -= ix0
        u -= 0.5
        u0 = math.floor(u)
        u -= u0
        i0 = min(max(int(u0), 0), nxm2)
        v += y
        v /= res
        v -= iy0
        v -= 0.5
        v0 = math.floor(v)
        v -= v0
        j0 = min(max(int(v0), 0), nym2)
        fu, fv = np.float32(u), np.float32(v)
        k = j0 * w + i0 + base
        a = fine[k] * (F32_ONE - fu) + fine[k + 1] * fu
        cc = fine[k + w] * (F32_ONE - fu) + fine[k + w + 1] * fu
        vals[b] = a * (F32_ONE - fv) + cc * fv
    return pairwise_sum(vals, 0, n)


@kernel
def penalty(x, y, th, p0, n, lin2, ang, prior, k):
    """``ScanMatcher._penalty`` of one candidate of particle k: the motion prior if ``prior`` has
    rows ((P, 5): mean x, y, theta, translation weight, rotation weight), else the pull to p0[k]
    (``lin2`` = max(lin, 1e-3) ** 2, ``ang`` = max(ang, 1e-3))."""
    if prior.shape[0] > 0:
        dx, dy = x - prior[k, 0], y - prior[k, 1]
        a = (th - prior[k, 2] + math.pi) % TWO_PI - math.pi
        return n * (prior[k, 3] * (dx * dx + dy * dy) + prior[k, 4] * a * a)
    dx, dy = x - p0[k, 0], y - p0[k, 1]
    d2 = (dx * dx + dy * dy) / lin2
    a = (th - p0[k, 2] + math.pi) % TWO_PI - math.pi
    q = a / ang
    return 0.05 * n * (d2 + q * q)


@kernel
def hill_climb(fine, consts, pose, p0, pts, res, lstep, astep, iterations, lin2, ang, prior):
    """gmapping's optimizer for every particle k (pose (P, 3) in field consts[k]): try +-x, +-y,
    +-theta, keep the best move if it improves the penalised score, else halve the steps; stop
    after ``iterations`` refinements (or 200 moves). Returns (poses (P, 3), plain scores (P,))."""
    P, n = pose.shape[0], pts.shape[0]
    out = pose.copy()
    scores = np.empty(P, np.float32)
    vals = np.empty(n, np.float32)
    cand = np.empty((6, 3))
    for k in range(P):
        ck = consts[k]
        x, y, th = out[k, 0], out[k, 1], out[k, 2]
        cur = (bilinear_sum(fine, ck, x, y, math.cos(th), math.sin(th), pts, res, vals)
               - penalty(x, y, th, p0, n, lin2, ang, prior, k))
        sx, sy, sa = lstep, lstep, astep
        refinements = 0
        for _ in range(200):
            if refinements > iterations:
                break
            for m in range(6):
                cand[m, 0], cand[m, 1], cand[m, 2] = x + 0.0 * sx, y + 0.0 * sy, th + 0.0 * sa
            cand[0, 0], cand[1, 0] = x + 1.0 * sx, x + -1.0 * sx
            cand[2, 1], cand[3, 1] = y + 1.0 * sy, y + -1.0 * sy
            cand[4, 2], cand[5, 2] = th + 1.0 * sa, th + -1.0 * sa
            c0, s0 = math.cos(cand[0, 2]), math.sin(cand[0, 2])
            best, top = -1, 0.0
            for m in range(6):
                if m < 4:
                    c, s = c0, s0
                else:
                    c, s = math.cos(cand[m, 2]), math.sin(cand[m, 2])
                sc = (bilinear_sum(fine, ck, cand[m, 0], cand[m, 1], c, s, pts, res, vals)
                      - penalty(cand[m, 0], cand[m, 1], cand[m, 2], p0, n, lin2, ang, prior, k))
                if best < 0 or sc > top:
                    best, top = m, sc
            if top > cur:
                x, y, th = cand[best, 0], cand[best, 1], cand[best, 2]
                cur = top
            else:
                sx /= 2
                sy /= 2
                sa /= 2
                refinements += 1
        th = (th + math.pi) % TWO_PI - math.pi
        out[k, 0], out[k, 1], out[k, 2] = x, y, th
        scores[k] = bilinear_sum(fine, ck, x, y, math.cos(th), math.sin(th), pts, res, vals)
    return out, scores


@kernel
def _leaf_sums(flat, base, lo, n, shifts, acc, res):
    """res[s] = numpy's block sum (n <= 128 values) of flat[base[lo:lo + n] + shifts[s]] for every
    shift s, beams in the outer loop (the shifts of one beam are neighbouring cells): each of the
    eight accumulators, then the tail, sees its values in numpy's order."""
    S = shifts.shape[0]
    m = n - n % 8 if n >= 8 else 0
    for i in range(n):
        k = base[lo + i]
        if i < 8 and m > 0:
            for q in range(S):
                acc[q, i] = flat[k + shifts[q]]
            continue
        if i == m:  # first value after the blocks of eight: fold the accumulators
            for q in range(S):
                if m > 0:
                    r = acc[q]
                    res[q] = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]))
                else:
                    res[q] = np.float32(0.0)
        if i < m:
            j = i % 8
            for q in range(S):
                acc[q, j] += flat[k + shifts[q]]
        else:
            for q in range(S):
                res[q] += flat[k + shifts[q]]
    if n == m:
        for q in range(S):
            if m > 0:
                r = acc[q]
                res[q] = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]))
            else:
                res[q] = np.float32(0.0)


@kernel
def grid_search(flat, off, w, nx, ny, ox, oy, pad, cell, poses, c, s, pts, half):
    """Scores (P, A, T) float32 of pose_p + (i cell, j cell) with heading (c, s)[p, a], T = (2 half
    + 1)^2 shifts in the order i * (2 half + 1) + j, beams read from the padded field p (flat
    buffer from off[p], row length w[p], nx[p] x ny[p] cells, map cell of its origin ox, oy in
    this level's cells); a beam's cell is clipped to one cell beyond the border (zeros).
    The sum over beams is numpy's pairwise float32 sum (``pairwise_sum``)."""
    P, A, n = c.shape[0], c.shape[1], pts.shape[0]
    R = 2 * half + 1
    S = R * R
    scores = np.empty((P, A, S), np.float32)
    base = np.empty(n, np.int64)
    vals = np.empty(n, np.float32)
    shifts = np.empty(S, np.int64)
    acc = np.empty((S, 8), np.float32)
    left, right = np.empty(S, np.float32), np.empty(S, np.float32)
    h = n // 2 - (n // 2) % 8  # numpy's split of a row of 129..248 values
    for p in range(P):
        for i in range(R):
            for j in range(R):
                shifts[i * R + j] = (i - half) + (j - half) * w[p]
        for a in range(A):
            ca, sa = c[p, a], s[p, a]
            for b in range(n):
                px, py = pts[b, 0], pts[b, 1]
                qy = sa * px + ca * py
                qy += poses[p, 1]
                qy /= cell
                qy -= oy[p]
                iy = min(max(int(math.floor(qy)), -half - 1), ny[p] + half) + pad
                qx = ca * px - sa * py
                qx += poses[p, 0]
                qx /= cell
                qx -= ox[p]
                ix = min(max(int(math.floor(qx)), -half - 1), nx[p] + half) + pad
                base[b] = iy * w[p] + ix + off[p]
            if n <= 128:
                _leaf_sums(flat, base, 0, n, shifts, acc, scores[p, a])
            elif n <= 248:
                _leaf_sums(flat, base, 0, h, shifts, acc, left)
                _leaf_sums(flat, base, h, n - h, shifts, acc, right)
                for q in range(S):
                    scores[p, a, q] = left[q] + right[q]
            else:
                for q in range(S):
                    for b in range(n):
                        vals[b] = flat[base[b] + shifts[q]]
                    scores[p, a, q] = pairwise_sum(vals, 0, n)
    return scores
