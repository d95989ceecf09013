"""A tiny pinhole renderer for tests: axis-aligned boxes in the base frame -> float32 depth image.

The camera pose is base <- camera_link (x forward, y left, z up); the optical frame (z forward,
x right, y down) is camera_link rotated by OPTICAL. Depth is the distance along the optical axis
(the ray direction has optical z = 1, so the hit parameter t is the depth); 0 where nothing is hit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from common.geometry import Transform
from common.messages import CameraInfo, Header

# camera_link <- camera optical frame (the usual -pi/2, 0, -pi/2 roll/pitch/yaw)
OPTICAL = Transform.from_xyz_rpy(0.0, 0.0, 0.0, -math.pi / 2, 0.0, -math.pi / 2)


@dataclass(frozen=True)
class Box:
    lo: tuple[float, float, float]
    hi: tuple[float, float, float]


def floor(size: float = 20.0) -> Box:
    return Box((-size, -size, -1.0), (size, size, 0.0))


def wall_x(x: float, thickness: float = 0.1, half_width: float = 20.0, height: float = 3.0) -> Box:
    """A wall whose front face is the plane x = ``x``."""
    return Box((x, -half_width, -1.0), (x + thickness, half_width, height))


def camera_info(width: int = 320, height: int = 240, fx: float = 262.5, fy: float | None = None,
                cx: float | None = None, cy: float | None = None, frame: str = "camera_depth_optical_frame"
                ) -> CameraInfo:
    cx = cx if cx is not None else (width - 1) / 2.0
    cy = cy if cy is not None else (height - 1) / 2.0
    return CameraInfo(Header(0.0, frame), width, height, fx, fy if fy is not None else fx, cx, cy)


def optical_pose(camera_link: Transform) -> Transform:
    """base <- optical frame."""
    return camera_link.compose(OPTICAL)


def render(boxes: list[Box], camera_link: Transform, info: CameraInfo) -> np.ndarray:
    u, v = np.meshgrid(np.arange(info.width, dtype=np.float64), np.arange(info.height, dtype=np.float64))
    d_opt = np.stack(((u - info.cx) / info.fx, (v - info.cy) / info.fy, np.ones_like(u)), axis=-1)
    d_opt = d_opt.reshape(-1, 3)
    pose = optical_pose(camera_link)
    d = d_opt @ pose.rotation.as_matrix().T
    o = pose.translation.as_array()
    best = np.full(len(d), np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / d
        for b in boxes:
            t1 = (np.asarray(b.lo) - o) * inv
            t2 = (np.asarray(b.hi) - o) * inv
            t1 = np.where(np.isnan(t1), -np.inf, t1)  # ray parallel to a slab and inside it
            t2 = np.where(np.isnan(t2), np.inf, t2)
            tmin = np.minimum(t1, t2).max(axis=1)
            tmax = np.maximum(t1, t2).min(axis=1)
            hit = (tmax >= tmin) & (tmin > 1e-9)
            best = np.where(hit & (tmin < best), tmin, best)
    best[~np.isfinite(best)] = 0.0
    return best.reshape(info.height, info.width).astype(np.float32)


def raycast_2d(boxes: list[Box], origin: tuple[float, float], angles: np.ndarray) -> np.ndarray:
    """Planar ranges from ``origin`` to the x-y footprints of ``boxes`` (+inf where nothing is hit)."""
    ang = np.asarray(angles, dtype=np.float64)
    d = np.stack((np.cos(ang), np.sin(ang)), axis=1)
    o = np.asarray(origin, dtype=np.float64)
    best = np.full(len(ang), np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / d
        for b in boxes:
            t1 = (np.asarray(b.lo[:2]) - o) * inv
            t2 = (np.asarray(b.hi[:2]) - o) * inv
            t1 = np.where(np.isnan(t1), -np.inf, t1)
            t2 = np.where(np.isnan(t2), np.inf, t2)
            tmin = np.minimum(t1, t2).max(axis=1)
            tmax = np.maximum(t1, t2).min(axis=1)
            hit = (tmax >= tmin) & (tmin > 0.0)
            best = np.where(hit & (tmin < best), tmin, best)
    return best


def wall_tolerance(dist: float, angles: np.ndarray, fx: float) -> np.ndarray:
    """How far a ray's range may be from dist / cos(angle) for a wall facing the camera.

    A ray carries the nearest pixel column(s), up to one column step (< 1 / fx rad) away in angle;
    the wall's range changes by dist * sin(a) / cos(a)^2 per radian.
    """
    a = np.abs(np.asarray(angles, dtype=np.float64))
    return dist * np.sin(a + 1.0 / fx) / np.cos(a + 1.0 / fx) ** 2 / fx + 1e-4
