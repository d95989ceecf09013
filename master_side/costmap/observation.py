"""Sensor observations as pure data (costmap_2d Observation / ObservationBuffer).

The node transforms sensor data into the costmap's global frame; the layers get points (N, 3) and the
sensor origin (3,), both in the global frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from common.messages import LaserScan
from master_side.costmap.layer_params import ObservationSourceParams

INF_RANGE_MARGIN = 1e-4  # ROS replaces +inf by range_max minus this when inf_is_valid


@dataclass(frozen=True)
class Observation:
    origin: np.ndarray  # (3,) sensor origin, global frame
    points: np.ndarray  # (N, 3) global frame, already height-filtered
    stamp: float
    source: ObservationSourceParams


def scan_to_points(scan: LaserScan, inf_is_valid: bool = False) -> np.ndarray:
    """LaserScan -> (N, 3) points in the scan's frame (z = 0), as laser_geometry projects them.

    Ranges outside [range_min, range_max) and NaN are dropped; with ``inf_is_valid`` +inf becomes
    range_max - 1e-4 (a free ray to the end of the range) as the ROS obstacle layer does.
    """
    r = np.asarray(scan.ranges, np.float64)
    a = scan.angles()
    if inf_is_valid:
        r = np.where(np.isposinf(r), scan.range_max - INF_RANGE_MARGIN, r)
    ok = np.isfinite(r) & (r >= scan.range_min)
    if scan.range_max > 0:
        ok &= r < scan.range_max
    r, a = r[ok], a[ok]
    return np.column_stack((r * np.cos(a), r * np.sin(a), np.zeros_like(r)))


class ObservationBuffer:
    """Keeps a source's recent observations; ``observation_persistence`` 0 keeps only the latest."""

    def __init__(self, name: str, params: ObservationSourceParams):
        self.name = name
        self.params = params
        self.observations: list[Observation] = []
        self.last_updated: float | None = None  # when the last reading was buffered (ROS last_updated_)
        self._last_stamp = 0.0

    def add(self, points: np.ndarray, origin: np.ndarray, stamp: float, received: float | None = None) -> None:
        """Buffer a reading: points (N, 3) and origin (3,) in the global frame, at time ``stamp`` (s).

        ``received``: the costmap's clock when the reading was buffered; ROS keeps that (not the stamp)
        as ``last_updated`` for ``is_current``. Without it the stamp stands in (pure callers, tests).
        """
        pts = np.asarray(points, np.float64).reshape(-1, 3)
        z = pts[:, 2]
        keep = (z >= self.params.min_obstacle_height) & (z <= self.params.max_obstacle_height)
        keep &= np.isfinite(pts).all(axis=1)
        origin = np.asarray(origin, np.float64).reshape(3)
        self.observations.append(Observation(origin, pts[keep], float(stamp), self.params))
        self.last_updated = float(stamp if received is None else received)
        self._last_stamp = float(stamp)
        self._purge()

    def _purge(self) -> None:
        """Keep readings within ``observation_persistence`` of the latest one's stamp (stamps only, so a
        clock offset between the sensor's machine and this one changes nothing)."""
        keep = self.params.observation_persistence
        if keep == 0.0:
            self.observations = self.observations[-1:]
        else:
            self.observations = [o for o in self.observations if self._last_stamp - o.stamp <= keep]

    def is_current(self, now: float) -> bool:
        """ROS ``isCurrent``: False when the last reading was buffered more than ``expected_update_rate``
        seconds before ``now`` (0 disables the check). A source that never delivered is not current.
        (zenav also reports a source that never delivered whatever the rate: ``costmap.health``.)"""
        rate = self.params.expected_update_rate
        if rate == 0.0:
            return True
        return self.last_updated is not None and now - self.last_updated <= rate

    def clear(self) -> None:
        self.observations = []
