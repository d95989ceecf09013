"""The sonar ring of a Pioneer 3-AT, and the points that put its echoes in a costmap.

A P3-AT carries 16 sonars, 8 at the front and 8 at the rear, each a transducer at a known place and heading
on the body (ARIA's robot parameters for the p3at, ``SonarUnit <number> <x mm> <y mm> <heading deg>``).
A sonar reports the distance of the nearest echo in its cone; the points here put that echo on the cone's
axis at that distance, in the base frame, for an obstacle layer to mark (and, for the far readings,
to clear along). The real bearing of the echo may be anywhere within the cone, so a point is placed up to
``range * sin(fov / 2)`` sideways of the echo: readings are used near the robot only (the costmap source's
``obstacle_range``), where a forward laser or camera does not look.
Pure: no bus.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from common.config import param

__all__ = ["P3AT_SONARS", "P3AT_UNITS", "SonarRingParams", "cone_points", "sonar_points", "used_sonars"]

# ARIA's ArRobotP3AT (ArRobotTypes.cpp; the same table as its p3at.p parameter file): number, x mm, y mm,
# heading deg. 0-7 the front ring from left (+y, facing +90 deg) to right, 8-15 the rear from right to left.
P3AT_SONARS: tuple[tuple[int, int, int, int], ...] = (
    (0, 147, 136, 90), (1, 193, 119, 50), (2, 227, 79, 30), (3, 245, 27, 10),
    (4, 245, -27, -10), (5, 227, -79, -30), (6, 193, -119, -50), (7, 147, -136, -90),
    (8, -144, -136, -90), (9, -189, -119, -130), (10, -223, -79, -150), (11, -241, -27, -170),
    (12, -241, 27, 170), (13, -223, 79, 150), (14, -189, 119, 130), (15, -144, 136, 90),
)


P3AT_UNITS: tuple[tuple[float, float, float], ...] = tuple(
    (x / 1000.0, y / 1000.0, math.radians(h)) for _, x, y, h in P3AT_SONARS)


@dataclass(frozen=True)
class SonarRingParams:
    units: tuple[tuple[float, float, float], ...] = param(
        P3AT_UNITS, unit="m, m, rad",
        doc="each sonar's (x, y, heading) in the base frame, in sonar-number order (default: the P3-AT's 16, "
            "ARIA's p3at table)")
    fov: float = param(math.radians(15.0), lo=0.001, hi=math.pi, unit="rad",
                       doc="a sonar's cone, full angle (Stage's Pioneer sonar model, pioneer.inc: 15 deg)")
    range_max: float = param(5.0, lo=0.1, hi=50.0, unit="m",
                             doc="no echo within it is reported as this value (Stage's Pioneer sonar: 5 m)")

    def validate(self) -> None:
        for i, u in enumerate(self.units):
            if len(u) != 3:
                raise ValueError(f"units[{i}] must be (x, y, heading), got {u!r}")


def used_sonars(use: tuple[int, ...], n: int) -> list[int]:
    """The sonar numbers in ``use`` (empty: all) below ``n``, in ``use``'s order."""
    return [i for i in (use or range(n)) if 0 <= i < n]


def _used(p: SonarRingParams, ranges: tuple[float, ...] | np.ndarray,
          use: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
    """(units (K, 3), readings (K,)) of the sonars in ``use`` (empty: all) that have both a unit and a reading."""
    r = np.asarray(ranges, dtype=np.float64)
    idx = np.array(used_sonars(use, min(len(r), len(p.units))), dtype=np.int64)
    return np.asarray(p.units, dtype=np.float64).reshape(-1, 3)[idx], r[idx]


def sonar_points(p: SonarRingParams, ranges: tuple[float, ...] | np.ndarray, use: tuple[int, ...] = (),
                 z: float = 0.2, max_range: float | None = None) -> np.ndarray:
    """(N, 3) float32 points in the base frame: sonar i's echo on its axis at ``ranges[i]``, for the sonars in
    ``use`` (empty: all). Readings that are not finite, not positive, or not below ``max_range`` (default the
    ring's ``range_max``: a reading at it is "no echo") give no point."""
    units, d = _used(p, ranges, use)
    limit = p.range_max if max_range is None else max_range
    ok = np.isfinite(d) & (d > 0.0) & (d < limit)
    units, d = units[ok], d[ok]
    pts = np.empty((d.size, 3), np.float32)
    pts[:, 0] = units[:, 0] + d * np.cos(units[:, 2])
    pts[:, 1] = units[:, 1] + d * np.sin(units[:, 2])
    pts[:, 2] = z
    return pts


def cone_points(p: SonarRingParams, ranges: tuple[float, ...] | np.ndarray, use: tuple[int, ...] = (),
                rays: int = 5, z: float = 0.2, short: float = 0.05, max_range: float | None = None) -> np.ndarray:
    """(N, 3) float32 points in the base frame across each used sonar's cone: ``rays`` bearings spread over its
    ``fov``, each ``short`` nearer than the sonar's reading (its nearest echo: nothing in the cone is nearer),
    or at ``max_range`` (default the ring's ``range_max``) with no echo. For a clearing-only costmap source:
    the space a sonar has heard empty, the whole cone rather than its axis. Unusable readings (not finite,
    not positive) give none."""
    units, d = _used(p, ranges, use)
    if rays < 1:
        return np.zeros((0, 3), np.float32)
    d = np.minimum(d, p.range_max if max_range is None else max_range)
    ok = np.isfinite(d) & (d > short)
    units, d = units[ok], d[ok] - short
    spread = np.linspace(-p.fov / 2.0, p.fov / 2.0, rays) if rays > 1 else np.zeros(1)
    bearing = (units[:, 2:3] + spread[None, :]).ravel()
    dist = np.repeat(d, len(spread))
    pts = np.empty((bearing.size, 3), np.float32)
    pts[:, 0] = np.repeat(units[:, 0], len(spread)) + dist * np.cos(bearing)
    pts[:, 1] = np.repeat(units[:, 1], len(spread)) + dist * np.sin(bearing)
    pts[:, 2] = z
    return pts
