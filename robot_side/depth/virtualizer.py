"""Virtual laser scans from a point cloud (the ira_laser_tools laserscan_virtualizer behaviour).

Each virtual scan plane is the x-y plane of a ``Transform`` (base_frame <- plane). Points whose
distance to the plane is within ``plane_half_thickness`` are projected onto it and binned by
bearing atan2(y, x) in the plane frame into ceil((angle_max - angle_min) / angle_increment) rays,
nearest planar range per ray. A point goes to the nearest ray, round((angle - angle_min) /
angle_increment) (ira_laser_tools truncates, which biases every ray by half an increment).
Returns closer than ``range_min`` or farther than ``range_max`` are dropped; empty bins are +inf.

All planes are processed at once: the cloud -> base transform is folded into the per-plane
matrices, the signed plane distances of all points come from one (N, 3) x (3, K) product, and
only the points inside a slab are projected.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from common.config import param
from common.geometry import Transform, Vector3
from common.messages import Header, LaserScan

__all__ = [
    "VirtualizerParams", "Virtualizer", "virtualize", "horizontal_planes", "oblique_planes",
    "tutorial_planes", "scan_bins",
]


def scan_bins(angle_min: float, angle_max: float, angle_increment: float) -> int:
    """Number of rays of a binned scan, as ira_laser_tools: ceil((max - min) / increment)."""
    return max(1, math.ceil((angle_max - angle_min) / angle_increment - 1e-9))


@dataclass(frozen=True)
class VirtualizerParams:
    base_frame: str = param("base_link", doc="frame the plane poses are given in")
    cloud_topic: str = param("camera/depth/points", doc="input PointCloud topic")
    output_laser_topic: str = param("", doc="'' = each scan on virtual_scans/<i>, else all on this topic")
    virtual_laser_scan: tuple[str, ...] = param((), doc="frame ids of the planes ('' = virtual_scan_<i>)")
    virtual_planes: tuple[tuple[float, ...], ...] = param(
        (), doc="(x, y, z, roll, pitch, yaw) of each plane in base_frame; empty = tutorial's 8 planes")
    angle_min: float = param(-3.14, lo=-math.pi, hi=math.pi, unit="rad")
    angle_max: float = param(3.14, lo=-math.pi, hi=math.pi, unit="rad")
    angle_increment: float = param(0.0058, lo=1e-5, hi=math.pi, unit="rad")
    time_increment: float = param(0.0, lo=0.0, unit="s")
    scan_time: float = param(0.0333333, lo=0.0, unit="s")
    range_min: float = param(0.0, lo=0.0, unit="m")
    range_max: float = param(25.0, lo=0.0, unit="m")
    plane_half_thickness: float = param(0.01, lo=0.0, hi=10.0, unit="m",
                                        doc="slab half-thickness around each plane (ROS: 0.01)")
    tf_wait_timeout: float = param(3.0, lo=0.0, unit="s", doc="how long to wait for the cloud->base TF")

    def validate(self) -> None:
        if self.angle_max <= self.angle_min:
            raise ValueError("angle_max must exceed angle_min")
        if self.range_max <= self.range_min:
            raise ValueError("range_max must exceed range_min")
        for i, p in enumerate(self.virtual_planes):
            if len(p) != 6:
                raise ValueError(f"virtual_planes[{i}] needs 6 numbers (x y z roll pitch yaw), got {len(p)}")
        if self.virtual_laser_scan and self.virtual_planes and \
                len(self.virtual_laser_scan) != len(self.virtual_planes):
            raise ValueError("virtual_laser_scan and virtual_planes must have the same length")

    def planes(self, sensor: Transform | None = None) -> list[Transform]:
        """The configured planes, or the tutorial's 8 horizontal planes around ``sensor`` (base <- sensor)."""
        if self.virtual_planes:
            return [Transform.from_xyz_rpy(*map(float, p)) for p in self.virtual_planes]
        return tutorial_planes(sensor or Transform())

    def frame_ids(self, n: int) -> list[str]:
        if self.virtual_laser_scan:
            return list(self.virtual_laser_scan)
        return [f"virtual_scan_{i}" for i in range(n)]


_ORIGIN = Vector3()


def horizontal_planes(origin: Vector3 = _ORIGIN, n: int = 8, below: float = 0.25, above: float = 0.90,
                      yaw: float = 0.0) -> list[Transform]:
    """``n`` horizontal planes through (origin.x, origin.y), from origin.z - below to origin.z + above."""
    zs = np.linspace(origin.z - below, origin.z + above, n) if n > 1 else np.array([origin.z])
    return [Transform.from_xyz_rpy(origin.x, origin.y, float(z), 0.0, 0.0, yaw) for z in zs]


def oblique_planes(origin: Vector3 = _ORIGIN, pitches: Sequence[float] = (0.3, -0.3), roll: float = 0.0,
                   yaw: float = 0.0) -> list[Transform]:
    """Planes through ``origin`` tilted by each pitch (positive pitch = looking down ahead, REP-103)."""
    return [Transform.from_xyz_rpy(origin.x, origin.y, origin.z, roll, float(p), yaw) for p in pitches]


def tutorial_planes(sensor: Transform) -> list[Transform]:
    """The tutorial's set-up: 8 horizontal planes from 0.25 m below to 0.90 m above the sensor origin."""
    return horizontal_planes(sensor.translation, 8, 0.25, 0.90, yaw=sensor.rotation.yaw)


class Virtualizer:
    """Precomputed plane geometry; ``ranges`` / ``scans`` run on every cloud (not thread-safe)."""

    CHUNK = 16384  # points per block: keeps the (K, CHUNK) work buffers in cache and reused

    def __init__(self, planes: Sequence[Transform], params: VirtualizerParams | None = None,
                 frame_ids: Sequence[str] | None = None):
        if not planes:
            raise ValueError("at least one plane is needed")
        self.params = p = params or VirtualizerParams()
        self.planes = list(planes)
        self.frame_ids = list(frame_ids) if frame_ids is not None else p.frame_ids(len(self.planes))
        if len(self.frame_ids) != len(self.planes):
            raise ValueError("one frame id per plane is needed")
        self.nbins = scan_bins(p.angle_min, p.angle_max, p.angle_increment)
        inv = [t.inverse() for t in self.planes]  # plane <- base
        self._r = np.stack([t.rotation.as_matrix() for t in inv])  # (K, 3, 3)
        self._t = np.stack([t.translation.as_array() for t in inv])  # (K, 3)
        self._dist = np.empty((len(self.planes), self.CHUNK), np.float32)
        self._inside = np.empty((len(self.planes), self.CHUNK), bool)

    def _folded(self, cloud_to_base: Transform | None) -> tuple[np.ndarray, np.ndarray]:
        """plane <- cloud as (K, 3, 3) rotations and (K, 3) translations."""
        if cloud_to_base is None:
            return self._r, self._t
        rc = cloud_to_base.rotation.as_matrix()
        tc = cloud_to_base.translation.as_array()
        return self._r @ rc, self._r @ tc + self._t

    def ranges(self, points: np.ndarray, cloud_to_base: Transform | None = None) -> np.ndarray:
        """(K, nbins) float32 ranges of (N, 3) ``points`` in base_frame (or mapped by ``cloud_to_base``)."""
        k = len(self.planes)
        out = np.full(k * self.nbins, np.inf, np.float32)
        pts = np.asarray(points, dtype=np.float32).reshape(-1, 3)
        r, t = self._folded(cloud_to_base)
        normals = np.ascontiguousarray(r[:, 2, :], dtype=np.float32)  # (K, 3)
        # Shift the signed plane distance so that the slab is [0, 2h]: then, for float32 bit
        # patterns, "inside" is one unsigned compare (negatives and NaN have larger patterns).
        h = self.params.plane_half_thickness
        shift = (t[:, 2] + h).astype(np.float32)[:, None]
        limit = np.array(2.0 * h, np.float32).view(np.uint32)
        sel_p, sel_k = [], []
        for c0 in range(0, len(pts), self.CHUNK):
            chunk = pts[c0:c0 + self.CHUNK]
            n = len(chunk)
            dist = np.matmul(normals, chunk.T, out=self._dist[:, :n])
            dist += shift
            inside = np.less_equal(dist.view(np.uint32), limit, out=self._inside[:, :n])
            flat = np.flatnonzero(inside)
            if len(flat):
                kk = flat // n
                sel_k.append(kk)
                sel_p.append(flat - kk * n + c0)
        if sel_p:
            self._bin(pts, np.concatenate(sel_p), np.concatenate(sel_k), r, t, out)
        return out.reshape(k, self.nbins)

    def _bin(self, pts: np.ndarray, pi: np.ndarray, ki: np.ndarray, r: np.ndarray, t: np.ndarray,
             out: np.ndarray) -> None:
        """Project points ``pi`` into planes ``ki`` and keep the nearest range per (plane, ray)."""
        p = self.params
        sel = np.stack([pts[:, j][pi] for j in range(3)], axis=1).astype(np.float64)
        x = np.einsum("ij,ij->i", sel, r[ki, 0, :]) + t[ki, 0]
        y = np.einsum("ij,ij->i", sel, r[ki, 1, :]) + t[ki, 1]
        rng = np.hypot(x, y)
        ang = np.arctan2(y, x)
        ok = (rng >= p.range_min) & (rng <= p.range_max) & (ang >= p.angle_min) & (ang <= p.angle_max)
        b = np.minimum(np.rint((ang[ok] - p.angle_min) / p.angle_increment).astype(np.int64), self.nbins - 1)
        np.minimum.at(out, ki[ok] * self.nbins + b, rng[ok].astype(np.float32))

    def scans(self, points: np.ndarray, stamp: float = 0.0,
              cloud_to_base: Transform | None = None) -> list[LaserScan]:
        p = self.params
        rs = self.ranges(points, cloud_to_base)
        return [
            LaserScan(
                header=Header(stamp, fid), angle_min=p.angle_min, angle_max=p.angle_max,
                angle_increment=p.angle_increment, time_increment=p.time_increment, scan_time=p.scan_time,
                range_min=p.range_min, range_max=p.range_max, ranges=rs[i].copy(),
            )
            for i, fid in enumerate(self.frame_ids)
        ]


def virtualize(points: np.ndarray, planes: Sequence[Transform], params: VirtualizerParams | None = None,
               stamp: float = 0.0, cloud_to_base: Transform | None = None) -> list[LaserScan]:
    """One-shot: one LaserScan per plane (frame ids from ``params``)."""
    return Virtualizer(planes, params).scans(points, stamp, cloud_to_base)
