"""hector_mapping's SLAM loop: match every scan against the multi-resolution map, update the map when
the pose moved more than the distance / angle thresholds since the last update. No odometry."""

from __future__ import annotations

import math

import numpy as np

from common.geometry import Pose2D, normalize_angle
from common.messages import LaserScan, OccupancyGrid
from master_side.hector.grid import GridLevel
from master_side.hector.matcher import match, score
from master_side.hector.params import HectorParams


def make_levels(p: HectorParams) -> list[GridLevel]:
    """The pyramid, finest first; every level covers the same square with the start at
    (map_start_x, map_start_y) of it."""
    side = p.map_size * p.map_resolution
    origin = (-p.map_start_x * side, -p.map_start_y * side)
    levels = []
    for k in range(p.map_multi_res_levels):
        f = 2 ** k
        levels.append(GridLevel(p.map_resolution * f, math.ceil(p.map_size / f), origin,
                                p.update_factor_free, p.update_factor_occupied, p.unknown_probability,
                                p.ignore_unknown))
    return levels


class HectorSlam:
    """``process(stamp, scan)`` -> pose of the base in the map (the first scan's pose is the origin,
    or ``start`` when given)."""

    def __init__(self, params: HectorParams, laser: Pose2D | None = None):
        self.p, self.laser = params, laser or Pose2D()
        self.levels = make_levels(params)
        self.pose: Pose2D | None = None
        self.covariance = np.eye(3)
        self._prev: tuple[float, Pose2D] | None = None
        self._last: tuple[float, Pose2D] | None = None
        self._last_update: Pose2D | None = None
        self._velocity: np.ndarray | None = None  # per scan (dx, dy, dθ) in the robot frame
        self._steps: list[np.ndarray] = []
        self.scans = 0
        w_xy = 1.0 / params.prior_sigma_xy ** 2 if params.prior_sigma_xy > 0 else 0.0
        w_th = 1.0 / params.prior_sigma_theta ** 2 if params.prior_sigma_theta > 0 else 0.0
        self._prior_w = np.array([w_xy, w_xy, w_th])
        self.map_updates = 0
        self._cache: tuple | None = None  # (angle_min, increment, n) -> beam unit vectors

    def scan_points(self, scan: LaserScan) -> np.ndarray:
        """Beam endpoints in the base frame, beams outside [laser_min_dist, laser_max_dist] dropped."""
        r = np.asarray(scan.ranges, float)
        key = (scan.angle_min, scan.angle_increment, len(r))
        if self._cache is None or self._cache[0] != key:
            a = scan.angle_min + scan.angle_increment * np.arange(len(r)) + self.laser.theta
            self._cache = (key, np.cos(a), np.sin(a))
        _, ca, sa = self._cache
        ok = np.isfinite(r) & (r >= self.p.laser_min_dist) & (r <= self.p.laser_max_dist)
        if scan.range_max > 0:
            ok &= r < scan.range_max
        r = r[ok]
        return np.column_stack((self.laser.x + r * ca[ok], self.laser.y + r * sa[ok]))

    def predict(self, stamp: float) -> Pose2D:
        """Constant-velocity prediction per scan from the last two poses (the last pose when there is
        one). Per scan, not per second: the logs' stamps are irregular (scans 1 ms and 0.4 s apart)
        while the scanner's period is not."""
        t1, p1 = self._last
        if not self.p.predict_velocity or self._prev is None:
            return p1
        v = self._velocity
        return p1.compose(Pose2D(*v)) if v is not None else p1

    def process(self, stamp: float, scan: LaserScan, start: Pose2D | None = None) -> Pose2D:
        """Match ``scan`` (``start``: an initial guess, e.g. from TF; default the prediction) and
        update the map when due. Returns the new pose."""
        pts = self.scan_points(scan)
        self.scans += 1
        if self._last is None:
            pose = start or Pose2D()
            self._update_map(pose, pts)
        else:
            guess = start if start is not None else self.predict(stamp)
            gap = self.p.gap_time > 0 and stamp - self._last[0] > self.p.gap_time
            pose = self._match(pts, guess, gap) if len(pts) >= 3 else guess
            lu = self._last_update
            if (math.hypot(pose.x - lu.x, pose.y - lu.y) > self.p.map_update_distance_thresh
                    or abs(normalize_angle(pose.theta - lu.theta)) > self.p.map_update_angle_thresh):
                self._update_map(pose, pts)
        self._prev, self._last = self._last, (stamp, pose)
        self._update_velocity()
        self.pose = pose
        return pose

    def _match(self, pts: np.ndarray, guess: Pose2D, gap: bool = False) -> Pose2D:
        """``gap``: after a gap in the scans, also match from the best pose of the wider gap_search_*
        window, and keep whichever match overlaps the map more (``score``)."""
        p = self.p
        est, self.covariance = match(self.levels, pts, guess.as_array(), p.coarse_iterations, p.fine_iterations,
                                     p.search_linear, p.search_angular, p.search_angular_step, self._prior_w)
        if gap:
            wide, cov = match(self.levels, pts, guess.as_array(), p.coarse_iterations, p.fine_iterations,
                              max(p.search_linear, p.gap_search_linear), max(p.search_angular, p.gap_search_angular),
                              p.search_angular_step, self._prior_w)
            if score(self.levels, pts, wide) > score(self.levels, pts, est):
                est, self.covariance = wide, cov
        return Pose2D(*est)

    def _update_velocity(self) -> None:
        """Per-scan velocity: the component-wise median of the last ``velocity_window`` steps, so one
        odd step (a scan out of order, a bad match) is not extrapolated; an implausible step resets it."""
        if self._prev is None:
            return
        d = self._prev[1].between(self._last[1])
        if math.hypot(d.x, d.y) > self.p.max_scan_motion_xy or abs(d.theta) > self.p.max_scan_motion_theta:
            self._steps.clear()
            self._velocity = None
            return
        self._steps.append(d.as_array())
        del self._steps[:-self.p.velocity_window]
        self._velocity = np.median(np.array(self._steps), axis=0)

    def _update_map(self, pose: Pose2D, pts: np.ndarray) -> None:
        ends = pose.apply(pts) if len(pts) else pts
        origin = pose.apply(np.array([[self.laser.x, self.laser.y]]))[0]
        for level in self.levels:
            level.update(origin, ends)
        self._last_update = pose
        self.map_updates += 1

    def occupancy_grid(self, stamp: float = 0.0, frame_id: str = "map", crop: bool = False) -> OccupancyGrid:
        return self.levels[0].occupancy_grid(stamp, frame_id, crop)
