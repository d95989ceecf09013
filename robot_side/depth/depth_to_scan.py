"""Depth image -> LaserScan (the depthimage_to_laserscan behaviour), fully vectorised.

Geometry (as depthimage_to_laserscan): a band of ``scan_height`` rows centred on the principal
row ``cy`` is used; pixel (u, v) with depth d (metres along the optical axis) is the point
x = (u - cx) d / fx, z = d in the optical frame, its range is the planar distance hypot(x, z)
= d * sqrt(1 + ((u - cx) / fx)^2) (the vertical offset is ignored) and its bearing is
atan((cx - u) / fx) (image left = positive angle, counter-clockwise, in ``output_frame_id``,
which is the x-forward / y-left frame of the camera, e.g. ``camera_depth_frame``).

angle_max = atan(cx / fx) (column 0), angle_min = -atan((W - 1 - cx) / fx) (last column),
angle_increment = (angle_max - angle_min) / (W - 1), W ranges; per output ray the nearest
in-range return of the band's pixels that fall on it wins.

Deliberate differences from the ROS node:
- "no return" is +inf (ROS leaves NaN); invalid depth (0, NaN, inf, negative) and ranges outside
  [range_min, range_max] are +inf and never hide a valid return behind them.
- column -> ray assignment rounds to the nearest ray and a ray that no column rounds to takes the
  column nearest to it (ROS truncates, which leaves empty NaN rays near the image centre where
  pixels are angularly sparser than the uniform rays).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from common.config import param
from common.messages import CameraInfo, DepthImage, Header, LaserScan

__all__ = ["DepthToScanParams", "ScanProjection", "DepthToScan", "depth_to_scan"]


@dataclass(frozen=True)
class DepthToScanParams:
    scan_height: int = param(1, lo=1, hi=10000, unit="px", doc="rows around the optical centre row used")
    scan_time: float = param(0.033, lo=0.0, unit="s", doc="time between scans (copied to the message)")
    range_min: float = param(0.45, lo=0.0, unit="m", doc="returns closer than this are dropped")
    range_max: float = param(10.0, lo=0.0, unit="m", doc="returns farther than this are dropped")
    output_frame_id: str = param("camera_depth_frame", doc="frame_id of the LaserScan (x fwd, y left)")

    def validate(self) -> None:
        if self.range_max <= self.range_min:
            raise ValueError(f"range_max ({self.range_max}) must exceed range_min ({self.range_min})")


@dataclass(frozen=True)
class ScanProjection:
    """Lookup tables for one (CameraInfo, scan_height): computed once, reused every frame."""

    width: int
    height: int
    row0: int  # first row of the band
    rows: int  # number of rows in the band
    angle_min: float
    angle_max: float
    angle_increment: float
    col_scale: np.ndarray  # (W,) float32: range = depth * col_scale
    gather: np.ndarray  # (W, K) int: ray i takes the min over columns gather[i, :]

    @staticmethod
    def build(info: CameraInfo, scan_height: int) -> ScanProjection:
        w, h = int(info.width), int(info.height)
        if w < 2 or h < 1 or info.fx <= 0.0:
            raise ValueError(f"unusable CameraInfo: {w}x{h} fx={info.fx}")
        rows = max(1, min(int(scan_height), h))
        row0 = int(info.cy - scan_height // 2)
        row0 = max(0, min(row0, h - rows))
        u = np.arange(w, dtype=np.float64)
        xn = (u - info.cx) / info.fx
        col_angle = np.arctan(-xn)  # atan((cx - u) / fx): decreasing with u
        a_max = math.atan(info.cx / info.fx)
        a_min = -math.atan((w - 1 - info.cx) / info.fx)
        inc = (a_max - a_min) / (w - 1)
        # Ray index i of column u, nearest ray; ray 0 is the rightmost column.
        col_ray = np.clip(np.rint((col_angle - a_min) / inc), 0, w - 1).astype(np.int64)
        ray_angle = a_min + inc * np.arange(w)
        # Nearest column for every ray (col_angle is monotonic decreasing).
        order = col_angle[::-1]  # increasing
        j = np.clip(np.searchsorted(order, ray_angle), 1, w - 1)
        nearer_left = (ray_angle - order[j - 1]) < (order[j] - ray_angle)
        nearest_col = (w - 1) - np.where(nearer_left, j - 1, j)
        counts = np.bincount(col_ray, minlength=w)
        k = max(1, int(counts.max()))
        gather = np.repeat(nearest_col[:, None], k, axis=1)
        # Columns rounding to ray i fill gather[i, 0:counts[i]]; the rest repeat the nearest column.
        cols_sorted = np.argsort(col_ray, kind="stable")
        starts = np.concatenate(([0], np.cumsum(counts)[:-1]))
        slot = np.arange(w) - np.repeat(starts, counts)
        gather[col_ray[cols_sorted], slot] = cols_sorted
        col_scale = np.sqrt(1.0 + xn * xn).astype(np.float32)
        return ScanProjection(w, h, row0, rows, a_min, a_max, inc, col_scale, gather)


class DepthToScan:
    """Converter with a per-CameraInfo lookup-table cache."""

    def __init__(self, params: DepthToScanParams | None = None):
        self.params = params or DepthToScanParams()
        self._key: tuple | None = None
        self._proj: ScanProjection | None = None

    def projection(self, info: CameraInfo) -> ScanProjection:
        key = (info.width, info.height, info.fx, info.fy, info.cx, info.cy, self.params.scan_height)
        if key != self._key:
            self._proj = ScanProjection.build(info, self.params.scan_height)
            self._key = key
        assert self._proj is not None
        return self._proj

    def ranges(self, depth: np.ndarray, info: CameraInfo) -> np.ndarray:
        """The (W,) float32 ranges, +inf where there is no valid in-range return."""
        pr = self.projection(info)
        if depth.shape != (pr.height, pr.width):
            raise ValueError(f"depth image is {depth.shape}, CameraInfo says {(pr.height, pr.width)}")
        p = self.params
        band = np.asarray(depth[pr.row0:pr.row0 + pr.rows], dtype=np.float32)
        r = band * pr.col_scale  # NaN stays NaN, 0 -> 0, inf -> inf
        # Keep only valid, in-range returns (comparisons with NaN are False).
        ok = (band > 0.0) & (r >= p.range_min) & (r <= p.range_max)
        r = np.where(ok, r, np.float32(np.inf))
        col = r.min(axis=0) if pr.rows > 1 else r[0]
        return col[pr.gather].min(axis=1)

    def convert(self, image: DepthImage, info: CameraInfo) -> LaserScan:
        pr = self.projection(info)
        p = self.params
        return LaserScan(
            header=Header(image.header.stamp, p.output_frame_id),
            angle_min=pr.angle_min,
            angle_max=pr.angle_max,
            angle_increment=pr.angle_increment,
            time_increment=0.0,
            scan_time=p.scan_time,
            range_min=p.range_min,
            range_max=p.range_max,
            ranges=self.ranges(image.depth, info),
        )


def depth_to_scan(image: DepthImage, info: CameraInfo, params: DepthToScanParams | None = None) -> LaserScan:
    """One-shot conversion (builds the lookup tables each call; use DepthToScan for streams)."""
    return DepthToScan(params).convert(image, info)
