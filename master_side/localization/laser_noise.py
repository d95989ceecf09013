"""The laser's noise measured, not guessed: amcl's ``laser_sigma_hit`` fitted to a log's scans against a map
and a trajectory of the same log (SLAM's, ``zenav slam run``), as odom_noise.py does for the odometry.

amcl's likelihood field scores each beam end point by its distance ``d`` to the nearest obstacle of the map
(likelihood_field.py): ``z_hit exp(-d² / 2σ²) + z_rand / range_max``. ROS's σ (0.2 m) is a guess for an
unknown laser and map. Given where the robot was, the end points' distances say what σ is: they are modelled
as a mixture of the hit part (a half-normal of deviation σ: the laser's noise, the map's cells and the pose's
own error together) and a uniform part over [0, ``laser_likelihood_max_dist``] (people, glass, what the map
lacks), and σ and the hit share are fitted by expectation-maximisation. Only σ goes to amcl: ROS's weights
leave the Gaussian unnormalised, so the fitted share is not its ``z_hit``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable

import numpy as np

from common.geometry import Pose2D
from master_side.localization.likelihood_field import LikelihoodField


@dataclass(frozen=True)
class LaserNoise:
    sigma_hit: float  # m
    hit_share: float  # the share of end points the hit part explains
    beams: int  # end points the fit saw
    iterations: int

    def yaml(self) -> str:
        """The line to put in amcl's parameters."""
        return f"laser_sigma_hit: {self.sigma_hit:.4g}"


def end_point_distances(field: LikelihoodField, poses: np.ndarray, scans: Iterable[tuple[np.ndarray, np.ndarray]],
                        laser: Pose2D, range_min: float, range_max: float) -> np.ndarray:
    """The likelihood field's distance at every usable beam end point (range_min <= r < range_max) of every
    scan ((ranges, angles) in the laser frame) seen from the base pose (N, 3) at its scan."""
    out = []
    for pose, (ranges, angles) in zip(np.asarray(poses, float), scans):
        r, a = np.asarray(ranges, float), np.asarray(angles, float)
        ok = np.isfinite(r) & (r >= range_min) & (r < range_max)
        ends = Pose2D(*pose).compose(laser).apply(np.column_stack((r[ok] * np.cos(a[ok]), r[ok] * np.sin(a[ok]))))
        out.append(field.distance_at(ends))
    return np.concatenate(out).astype(float) if out else np.zeros(0)


def fit(distances: np.ndarray, max_dist: float, sigma0: float = 0.2, share0: float = 0.9,
        tol: float = 1e-7, max_iter: int = 500) -> LaserNoise:
    """σ and the hit share of ``distances`` (>= 0, saturated at ``max_dist``) by EM: half-normal(σ) hits,
    uniform on [0, max_dist] for the rest."""
    d = np.asarray(distances, float)
    if d.ndim != 1 or len(d) < 10:
        raise ValueError(f"need at least 10 beam end points, got {d.size}")
    if not max_dist > 0.0:
        raise ValueError(f"max_dist must be > 0, got {max_dist}")
    d2 = np.minimum(d, max_dist) ** 2
    sigma, share, iterations = sigma0, share0, 0
    while iterations < max_iter:
        iterations += 1
        hit = share * math.sqrt(2.0 / math.pi) / sigma * np.exp(-d2 / (2.0 * sigma**2))
        resp = hit / (hit + (1.0 - share) / max_dist)
        total = float(resp.sum())
        if total <= 0.0:
            raise ValueError("no end point lies near the map's obstacles: wrong map or trajectory?")
        new_sigma = max(math.sqrt(float((resp * d2).sum()) / total), 1e-6)
        new_share = min(max(total / len(d), 1e-9), 1.0 - 1e-9)
        done = abs(new_sigma - sigma) < tol * sigma and abs(new_share - share) < tol
        sigma, share = new_sigma, new_share
        if done:
            break
    return LaserNoise(sigma, share, len(d), iterations)
