"""Particle-set pieces of AMCL: KLD-adaptive resampling and pose clusters (pure numpy).

KLD sampling (Fox 2003): draw particles until their count exceeds the bound for the number ``k`` of
histogram bins they occupy, ``n = (k-1)/(2 kld_err) · (1 - 2/(9(k-1)) + sqrt(2/(9(k-1))) kld_z)³``,
clamped to [min_particles, max_particles]. Bins are 0.5 m × 0.5 m × 10°, as in ROS amcl's kd-tree.
Clusters are connected groups of occupied bins (26-neighbourhood, yaw wrapping around); the filter's
estimate is the mean of the heaviest cluster, like ROS amcl's best hypothesis.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from common.geometry import Pose2D

BIN_XY = 0.5  # m
BIN_YAW = math.radians(10.0)
N_YAW = int(round(2 * math.pi / BIN_YAW))
_OFF, _SPAN = 1 << 19, 1 << 20


def bins(poses: np.ndarray) -> np.ndarray:
    """(N, 3) integer histogram bins (ix, iy, iyaw) of poses (N, 3)."""
    ix = np.floor(poses[:, 0] / BIN_XY)
    iy = np.floor(poses[:, 1] / BIN_XY)
    ia = np.floor((poses[:, 2] % (2 * math.pi)) / BIN_YAW) % N_YAW
    return np.column_stack((ix, iy, ia)).astype(np.int64)


def bin_keys(b: np.ndarray) -> np.ndarray:
    """One int64 key per bin row (ix, iy, iyaw)."""
    return ((b[:, 0] + _OFF) * _SPAN + (b[:, 1] + _OFF)) * N_YAW + (b[:, 2] % N_YAW)


def kld_limit(k: np.ndarray | int, err: float, z: float) -> np.ndarray:
    """Particles needed for ``k`` occupied bins (0 for k <= 1: the minimum count then applies)."""
    k = np.asarray(k, float)
    km1 = np.maximum(k - 1.0, 1.0)
    b = 2.0 / (9.0 * km1)
    n = np.ceil(km1 / (2.0 * err) * (1.0 - b + np.sqrt(b) * z) ** 3)
    return np.where(k <= 1, 0.0, n)


def systematic_indices(weights: np.ndarray, count: int, rng: np.random.Generator) -> np.ndarray:
    """``count`` indices drawn with probability ``weights`` (low-variance sampler, one offset)."""
    cum = np.cumsum(weights)
    cum /= cum[-1]
    positions = (rng.random() + np.arange(count)) / count
    return np.searchsorted(cum, positions, side="right").clip(0, len(weights) - 1)


def kld_resample(poses: np.ndarray, weights: np.ndarray, min_n: int, max_n: int, err: float, z: float,
                 rng: np.random.Generator, random_fraction: float = 0.0,
                 random_poses: Callable[[int], np.ndarray] | None = None) -> np.ndarray:
    """New particle poses (n, 3), ``min_n <= n <= max_n``, equally weighted.

    Each draw is a uniformly random pose (``random_poses(m)``) with probability ``random_fraction``
    (AMCL's recovery), else a copy of a particle chosen by weight. Draws come in random order, so any
    prefix is a fair sample; the prefix stops where its size reaches the KLD bound of its bins."""
    cand = poses[rng.permutation(systematic_indices(weights, max_n, rng))]
    if random_fraction > 0.0 and random_poses is not None:
        rnd = rng.random(max_n) < random_fraction
        if rnd.any():
            cand[rnd] = random_poses(int(rnd.sum()))
    _, first = np.unique(bin_keys(bins(cand)), return_index=True)
    is_new = np.zeros(max_n, bool)
    is_new[first] = True
    k = np.cumsum(is_new)
    count = np.arange(1, max_n + 1)
    ok = (count >= kld_limit(k, err, z)) & (count >= min_n)
    n = int(np.argmax(ok)) + 1 if ok.any() else max_n
    return cand[:n].copy()


def clusters(poses: np.ndarray) -> np.ndarray:
    """Cluster label per particle: connected occupied bins (26-neighbourhood, yaw wraps)."""
    b = bins(poses)
    keys = bin_keys(b)
    ukeys, inverse = np.unique(keys, return_inverse=True)
    ub = b[np.unique(inverse, return_index=True)[1]]  # one bin row per unique key (sorted like ukeys)
    src, dst = [], []
    for dx in (-1, 0, 1):
        for dy in (-1, 0, 1):
            for da in (-1, 0, 1):
                if dx == dy == da == 0:
                    continue
                nk = bin_keys(ub + np.array([dx, dy, da]))
                pos = np.searchsorted(ukeys, nk).clip(0, len(ukeys) - 1)
                hit = ukeys[pos] == nk
                src.append(np.nonzero(hit)[0])
                dst.append(pos[hit])
    m = len(ukeys)
    s, d = np.concatenate(src), np.concatenate(dst)
    graph = coo_matrix((np.ones(len(s)), (s, d)), shape=(m, m))
    _, labels = connected_components(graph, directed=False)
    return labels[inverse.ravel()]


def weighted_stats(poses: np.ndarray, weights: np.ndarray) -> tuple[Pose2D, np.ndarray]:
    """Weighted mean pose (circular mean yaw) and 3×3 covariance (x, y block; yaw -2 ln R, as ROS)."""
    w = weights / weights.sum()
    mx, my = float(w @ poses[:, 0]), float(w @ poses[:, 1])
    c, s = float(w @ np.cos(poses[:, 2])), float(w @ np.sin(poses[:, 2]))
    dx, dy = poses[:, 0] - mx, poses[:, 1] - my
    cov = np.zeros((3, 3))
    cov[0, 0], cov[1, 1] = w @ (dx * dx), w @ (dy * dy)
    cov[0, 1] = cov[1, 0] = w @ (dx * dy)
    cov[2, 2] = -2.0 * math.log(max(math.hypot(c, s), 1e-12))
    return Pose2D(mx, my, math.atan2(s, c)), cov


def heaviest_cluster(poses: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, float]:
    """The particles of the heaviest cluster (a mask) and that cluster's share of the total weight."""
    labels = clusters(poses)
    totals = np.bincount(labels, weights=weights)
    best = int(np.argmax(totals))
    return labels == best, float(totals[best] / totals.sum())


def best_cluster_estimate(poses: np.ndarray, weights: np.ndarray) -> tuple[Pose2D, np.ndarray, float]:
    """Mean and covariance of the heaviest cluster, and that cluster's share of the total weight."""
    sel, share = heaviest_cluster(poses, weights)
    mean, cov = weighted_stats(poses[sel], weights[sel])
    return mean, cov, share
