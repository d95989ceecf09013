"""Merge several LaserScans into one (the ira_laser_tools laserscan_multi_merger behaviour).

Every input scan is projected to points (returns within its own [range_min, range_max]), moved
into ``destination_frame`` with its Transform (destination <- scan frame) and concatenated into
the merged cloud. The cloud is flattened onto the destination x-y plane (z is ignored, as in ROS)
and binned into ceil((angle_max - angle_min) / angle_increment) rays, each point to the nearest
ray round((atan2(y, x) - angle_min) / angle_increment) (ROS truncates), nearest planar range per
ray. Points closer
than ``range_min``, farther than ``range_max`` or outside [angle_min, angle_max] are dropped;
empty bins are +inf (ROS writes range_max + 1).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from common.config import param
from common.geometry import Transform
from common.messages import Header, LaserScan, PointCloud
from robot_side.depth.virtualizer import scan_bins

__all__ = ["MergerParams", "scan_to_points", "merge_scans", "bin_points", "ScanMerger"]


@dataclass(frozen=True)
class MergerParams:
    destination_frame: str = param("base_link", doc="frame of the merged scan and cloud")
    cloud_destination_topic: str = param("merged_cloud", doc="merged PointCloud topic")
    scan_destination_topic: str = param("scan", doc="merged LaserScan topic")
    laserscan_topics: tuple[str, ...] | str = param(
        tuple(f"virtual_scans/{i}" for i in range(8)), doc="scan topics to merge (list or space-separated)")
    angle_min: float = param(-2.36, lo=-math.pi, hi=math.pi, unit="rad")
    angle_max: float = param(2.36, lo=-math.pi, hi=math.pi, unit="rad")
    angle_increment: float = param(0.0058, lo=1e-5, hi=math.pi, unit="rad")
    time_increment: float = param(0.0, lo=0.0, unit="s")
    scan_time: float = param(0.0333333, lo=0.0, unit="s")
    range_min: float = param(0.45, lo=0.0, unit="m")
    range_max: float = param(25.0, lo=0.0, unit="m")
    max_scan_age: float = param(0.5, lo=0.0, unit="s",
                                doc="inputs older than this (vs the newest) are left out")
    tf_wait_timeout: float = param(3.0, lo=0.0, unit="s", doc="TF wait per scan (tutorial: 1 s -> 3 s)")

    def validate(self) -> None:
        if self.angle_max <= self.angle_min:
            raise ValueError("angle_max must exceed angle_min")
        if self.range_max <= self.range_min:
            raise ValueError("range_max must exceed range_min")
        if not self.topics():
            raise ValueError("laserscan_topics is empty")

    def topics(self) -> tuple[str, ...]:
        t = self.laserscan_topics
        items = t.split() if isinstance(t, str) else t
        return tuple(dict.fromkeys(s.lstrip("/") for s in items if s))  # unique, order kept


def scan_to_points(scan: LaserScan, transform: Transform | None = None) -> np.ndarray:
    """(N, 3) float32 points of the valid returns of ``scan``, mapped by ``transform`` (dest <- scan)."""
    r = np.asarray(scan.ranges, dtype=np.float64)
    a = scan.angle_min + scan.angle_increment * np.arange(len(r))
    ok = np.isfinite(r) & (r >= scan.range_min) & (r <= scan.range_max)
    r, a = r[ok], a[ok]
    pts = np.column_stack((r * np.cos(a), r * np.sin(a), np.zeros_like(r)))
    if transform is not None:
        pts = transform.apply(pts)
    return pts.astype(np.float32)


def bin_points(points: np.ndarray, params: MergerParams) -> np.ndarray:
    """Nearest planar range per angular bin of (N, 3) points (z ignored); +inf for empty bins."""
    p = params
    n = scan_bins(p.angle_min, p.angle_max, p.angle_increment)
    out = np.full(n, np.inf, np.float32)
    if len(points) == 0:
        return out
    x = points[:, 0].astype(np.float64)
    y = points[:, 1].astype(np.float64)
    rng = np.hypot(x, y)
    ang = np.arctan2(y, x)
    ok = (rng >= p.range_min) & (rng <= p.range_max) & (ang >= p.angle_min) & (ang <= p.angle_max)
    b = np.minimum(np.rint((ang[ok] - p.angle_min) / p.angle_increment).astype(np.int64), n - 1)
    np.minimum.at(out, b, rng[ok].astype(np.float32))
    return out


def merge_scans(pairs: Iterable[tuple[LaserScan, Transform]], params: MergerParams | None = None,
                stamp: float | None = None) -> tuple[LaserScan, PointCloud]:
    """Merge (scan, destination <- scan frame) pairs; stamp defaults to the newest input stamp."""
    p = params or MergerParams()
    pairs = list(pairs)
    clouds = [scan_to_points(s, t) for s, t in pairs]
    cloud = np.concatenate(clouds) if clouds else np.zeros((0, 3), np.float32)
    if stamp is None:
        stamp = max((s.header.stamp for s, _ in pairs), default=0.0)
    header = Header(stamp, p.destination_frame)
    scan = LaserScan(
        header=header, angle_min=p.angle_min, angle_max=p.angle_max, angle_increment=p.angle_increment,
        time_increment=p.time_increment, scan_time=p.scan_time, range_min=p.range_min,
        range_max=p.range_max, ranges=bin_points(cloud, p),
    )
    return scan, PointCloud(header, cloud)


class ScanMerger:
    """Keeps the latest scan (and its transform to destination_frame) per input topic.

    ``ready()`` follows the ROS node (merge once every input has delivered a new scan) but does
    not wait for inputs that have never arrived or that went stale (older than ``max_scan_age``
    relative to ``now``), so one dead input does not stop the merged output.
    """

    def __init__(self, params: MergerParams | None = None, topics: Sequence[str] | None = None):
        self.params = params or MergerParams()
        self.topics = tuple(topics) if topics is not None else self.params.topics()
        self._latest: dict[str, tuple[LaserScan, Transform]] = {}
        self._fresh: set[str] = set()  # topics updated since the last merge

    def update(self, topic: str, scan: LaserScan, transform: Transform) -> None:
        """Store ``scan`` with its destination <- scan frame transform."""
        topic = topic.lstrip("/")
        if topic not in self.topics:
            raise KeyError(f"unknown scan topic {topic!r} (expected one of {list(self.topics)})")
        self._latest[topic] = (scan, transform)
        self._fresh.add(topic)

    def _alive(self, now: float) -> list[str]:
        age = self.params.max_scan_age
        return [t for t, (s, _) in self._latest.items() if now - s.header.stamp <= age]

    def ready(self, now: float) -> bool:
        """True when every live input has a new scan since the last merge (and at least one is new)."""
        alive = self._alive(now)
        return bool(alive) and all(t in self._fresh for t in alive)

    def merge(self, now: float | None = None,
              stamp: float | None = None) -> tuple[LaserScan, PointCloud] | None:
        """Merge the inputs no older than max_scan_age before ``now`` (default: the newest stamp)."""
        if not self._latest:
            return None
        if now is None:
            now = max(s.header.stamp for s, _ in self._latest.values())
        alive = self._alive(now)
        if not alive:
            return None
        self._fresh.clear()
        return merge_scans([self._latest[t] for t in self.topics if t in alive], self.params, stamp)
