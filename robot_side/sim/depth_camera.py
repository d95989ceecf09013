"""Simulated Kinect-like depth camera over the 2.5D world (height grid + floor plane z = 0).

The camera is level (no pitch/roll: the column trick below needs vertical image columns); it is mounted
at (x, y, z, yaw) in base_link. Pixel (u, v) looks along ((u - cx)/fx, (v - cy)/fy, 1) in the optical
frame (z forward, x right, y down). All pixels of column u share one horizontal ray, so each frame is:

* the (column, surface cell) pairs whose horizontal ray crosses the cell (exact slab test, ``raycast``),
  giving the depth interval [d_in, d_out] of the crossing;
* a cell of height h stops row v iff the ray is below h somewhere in the cell:
  t_v = (v - cy)/fy > (z - h)/d, with d = d_in when h >= z (rays going up) and d_out when h < z,
  so each pair hits every row from ``row_start`` down: a scatter-min into (row_start, column) plus a
  cumulative minimum down the rows gives the first hit of every pixel;
* the floor: rows below the horizon see depth z / t_v.

Depth is metres along the optical axis (float32, 0 = invalid: outside [range_min, range_max]).
Noise: std = noise_std + noise_z2 * depth^2 (Kinect-like quadratic growth), drawn from a seeded pool.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from common.config import load_params, param
from common.geometry import Pose2D
from common.messages import CameraInfo, DepthImage, Header
from robot_side.sim.raycast import candidates, expand_pairs, ray_square, safe_inverse, surface_cells
from robot_side.sim.world import World

__all__ = ["DepthCameraParams", "DepthCamera", "DEPTH_MODES"]

# openni depth_mode / image_mode -> (width, height)
DEPTH_MODES = {2: (640, 480), 5: (320, 240), 8: (160, 120)}


@dataclass(frozen=True)
class DepthCameraParams:
    depth_mode: int = param(5, choices=(2, 5, 8), doc="openni depth mode: 2 VGA, 5 QVGA, 8 QQVGA")
    data_skip: int = param(0, lo=0, hi=1000, doc="frames dropped for each one published (openni driver)")
    rate: float = param(30.0, lo=0.1, hi=1000.0, unit="Hz", doc="native frame rate before data_skip")
    hfov: float = param(math.radians(57.0), lo=0.1, hi=3.0, unit="rad", doc="horizontal field of view")
    vfov: float = param(math.radians(43.0), lo=0.1, hi=3.0, unit="rad", doc="vertical field of view")
    range_min: float = param(0.5, lo=0.0, hi=100.0, unit="m", doc="nearer depths are invalid (0)")
    range_max: float = param(4.5, lo=0.01, hi=100.0, unit="m", doc="farther depths are invalid (0)")
    noise_std: float = param(0.0, lo=0.0, hi=1.0, unit="m", doc="constant part of the depth noise std")
    noise_z2: float = param(0.0015, lo=0.0, hi=1.0, unit="1/m", doc="quadratic part: std += noise_z2*depth^2")
    x: float = param(0.1, lo=-10.0, hi=10.0, unit="m", doc="mount x in base_link")
    y: float = param(0.0, lo=-10.0, hi=10.0, unit="m", doc="mount y in base_link")
    z: float = param(0.35, lo=0.01, hi=10.0, unit="m", doc="mount height (camera is level)")
    yaw: float = param(0.0, lo=-math.pi, hi=math.pi, unit="rad", doc="mount yaw in base_link")
    frame_id: str = param("camera_depth_optical_frame", doc="optical frame of the image")
    seed: int = param(2, lo=0, doc="noise RNG seed")

    def validate(self) -> None:
        if self.range_max <= self.range_min:
            raise ValueError("range_max must be greater than range_min")

    @property
    def size(self) -> tuple[int, int]:
        return DEPTH_MODES[self.depth_mode]

    @property
    def publish_rate(self) -> float:
        return self.rate / (self.data_skip + 1)

    @property
    def mount(self) -> Pose2D:
        return Pose2D(self.x, self.y, self.yaw)

    def intrinsics(self) -> tuple[float, float, float, float]:
        """(fx, fy, cx, cy): focal lengths from the FOVs, principal point at the image centre."""
        w, h = self.size
        return (w / 2) / math.tan(self.hfov / 2), (h / 2) / math.tan(self.vfov / 2), (w - 1) / 2, (h - 1) / 2


def load_depth_camera_params(mapping: dict | None, source: str = "<config>",
                             section: str = "depth_camera") -> DepthCameraParams:
    return load_params(DepthCameraParams, mapping, source, section, ignore=("image_mode",))


class DepthCamera:
    """Renders ``DepthImage`` + ``CameraInfo`` of a ``World`` from a robot pose."""

    def __init__(self, world: World, params: DepthCameraParams = DepthCameraParams()):
        self.world, self.p = world, params
        self.width, self.height = params.size
        self.fx, self.fy, self.cx, self.cy = params.intrinsics()
        self.refresh()
        u = np.arange(self.width)
        self.col_angle = np.arctan2(self.cx - u, self.fx)  # left positive, relative to the optical axis
        self.col_cos = np.cos(self.col_angle)
        self.row_t = (np.arange(self.height) - self.cy) / self.fy
        with np.errstate(divide="ignore"):
            fl = np.where(self.row_t > 0, params.z / self.row_t, np.inf)
        self.floor_depth = fl.astype(np.float32)[:, None]
        self.rng = np.random.default_rng(params.seed)
        n = self.width * self.height
        self._pool = self.rng.standard_normal(3 * n, dtype=np.float32) if self._noisy else None

    def refresh(self) -> None:
        """Re-read the world's surface (after ``World.add_box``)."""
        w = self.world
        self.cells = surface_cells(w.heights, w.origin, w.resolution, eye_z=self.p.z)

    @property
    def _noisy(self) -> bool:
        return self.p.noise_std > 0 or self.p.noise_z2 > 0

    def sensor_pose(self, robot: Pose2D) -> Pose2D:
        return robot.compose(self.p.mount)

    def camera_info(self, stamp: float = 0.0) -> CameraInfo:
        return CameraInfo(Header(stamp, self.p.frame_id), self.width, self.height,
                          self.fx, self.fy, self.cx, self.cy)

    def depth_exact(self, robot: Pose2D) -> np.ndarray:
        """Noise-free depth (H, W) float32, +inf where nothing is hit (before range invalidation)."""
        p, res = self.p, self.world.resolution
        s = self.sensor_pose(robot)
        w, h = self.width, self.height
        # farthest horizontal distance a valid pixel can need: range_max at the image's edge column
        reach = p.range_max / float(self.col_cos.min())
        ci, bearing, half, _ = candidates(self.cells, s.x, s.y, s.theta, reach)
        lim = math.pi / 2 - 1e-6
        lo = np.ceil(self.cx - self.fx * np.tan(np.minimum(bearing + half, lim)))
        hi = np.floor(self.cx - self.fx * np.tan(np.maximum(bearing - half, -lim)))
        front = np.abs(bearing) < math.pi / 2 + half
        lo = np.maximum(lo, 0).astype(np.int64)
        hi = np.minimum(hi, w - 1).astype(np.int64)
        ok = front & (hi >= lo)
        which, col = expand_pairs(lo[ok], hi[ok])
        cell = ci[ok][which]
        ang = self.col_angle + s.theta
        inv_dx, inv_dy = safe_inverse(np.cos(ang)), safe_inverse(np.sin(ang))
        s_in, s_out = ray_square(self.cells.x0[cell] - s.x, self.cells.y0[cell] - s.y,
                                 inv_dx[col], inv_dy[col], res)
        np.maximum(s_in, 1e-9, out=s_in)
        hit = s_out > s_in
        cell, col, s_in, s_out = cell[hit], col[hit], s_in[hit], s_out[hit]
        c = self.col_cos[col]
        d_in, d_out = s_in * c, s_out * c
        dz = p.z - self.cells.h[cell]
        g = np.where(dz <= 0, dz / d_in, dz / d_out)
        row = np.floor(np.clip(self.cy + self.fy * g, -2.0, h + 1.0)).astype(np.int64) + 1
        np.clip(row, 0, h, out=row)
        return self._compose(col, row, d_in)

    def _compose(self, col: np.ndarray, row: np.ndarray, depth: np.ndarray) -> np.ndarray:
        """Pixel (v, u) = min(floor depth of row v, min depth of the events of column u with row <= v).

        Events are sorted by (column, row) with one 'no hit' sentinel at row 0 of every column; a running
        minimum that restarts per column (values shifted by -column * BIG so earlier columns never win)
        gives each column's step function, expanded column-major with ``np.repeat``, transposed once.
        """
        w, h = self.width, self.height
        cap, big = 1.0e4, 2.0e4
        cols = np.concatenate((np.arange(w), col))
        rows = np.concatenate((np.zeros(w, np.int64), row))
        vals = np.concatenate((np.full(w, cap), np.minimum(depth, cap)))
        real = np.concatenate((np.zeros(w, np.int64), np.ones(len(col), np.int64)))  # sentinels sort first
        key = (cols * (h + 1) + rows) * 2 + real
        order = np.argsort(key, kind="stable")
        cols, rows, vals = cols[order], rows[order], vals[order]
        run = np.minimum.accumulate(vals - cols * big) + cols * big
        nxt = np.empty_like(rows)
        nxt[:-1] = rows[1:]
        nxt[-1] = h
        last = np.empty(len(cols), bool)
        last[:-1] = cols[1:] != cols[:-1]
        last[-1] = True
        nxt[last] = h
        run32 = run.astype(np.float32)
        run32[run >= cap] = np.inf
        colmajor = np.repeat(run32, nxt - rows).reshape(w, h)
        return np.minimum(colmajor.T, self.floor_depth)

    def frame(self, robot: Pose2D, stamp: float = 0.0) -> DepthImage:
        p = self.p
        img = self.depth_exact(robot)
        invalid = (img < p.range_min) | (img > p.range_max)
        img[invalid] = 0.0
        if self._pool is not None:
            n = img.size
            k = int(self.rng.integers(0, len(self._pool) - n))
            noise = self._pool[k:k + n].reshape(img.shape) * img  # std = noise_std + noise_z2 * d^2
            noise *= img
            noise *= np.float32(p.noise_z2)
            if p.noise_std > 0:
                noise += np.float32(p.noise_std) * self._pool[k:k + n].reshape(img.shape)
            img += noise
            img[invalid] = 0.0
        return DepthImage(Header(stamp, p.frame_id), img)
