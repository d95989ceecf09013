"""Offline SLAM over a log: progress on stderr, map.pgm/map.yaml and trajectory.txt in an output folder."""

from __future__ import annotations

import sys
import time
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

import numpy as np

from common.geometry import Pose2D
from master_side.mapping.map_io import save_map
from master_side.slam.gridslam import GridSlam
from master_side.slam.logs import ScanRecord, read_log
from master_side.slam.params import GMappingParams


@dataclass
class RunResult:
    stamps: np.ndarray  # (N,) every scan's stamp
    poses: np.ndarray  # (N, 3) estimated pose of every scan
    scans: int
    processed: int
    data_s: float
    wall_s: float
    slam: GridSlam
    cpu_s: float = 0.0  # process CPU time (wall time suffers on a shared machine)
    update_cpu_s: float = 0.0  # CPU time of the filter updates (the scans the particles integrated)

    @property
    def update_ms(self) -> float:
        """Mean CPU time of one filter update (all particles), ms."""
        return 1000.0 * self.update_cpu_s / self.processed if self.processed else 0.0

    @property
    def realtime_factor(self) -> float:
        """Data time / wall time (> 1 means faster than real time)."""
        return self.data_s / self.wall_s if self.wall_s > 0 else float("inf")


def full_trajectory(odoms: list[Pose2D], processed: list[tuple[int, Pose2D]],
                    between: dict[int, tuple[int, np.ndarray]] | None = None) -> np.ndarray:
    """Pose of every scan: processed scans from the filter; a skipped scan tracked against the map
    (``between``: index -> (processed index, relative pose)) from that scan's smoothed pose; any
    other from the nearest processed scan plus the odometry increment between the two."""
    idx = np.array([i for i, _ in processed])
    at = dict(processed)
    between = between or {}
    out = np.zeros((len(odoms), 3))
    for i, odom in enumerate(odoms):
        b = between.get(i)
        if b is not None and b[0] in at:
            out[i] = at[b[0]].compose(Pose2D(*b[1])).as_array()
            continue
        k = int(np.searchsorted(idx, i))
        if k == len(idx) or (k > 0 and i - idx[k - 1] <= idx[k] - i):
            k -= 1
        j, pose = processed[k]
        out[i] = pose.compose(odoms[j].between(odom)).as_array()
    return out


def run(log: str | Path, params: GMappingParams, max_scans: int | None = None,
        progress: TextIO | None = sys.stderr, every_s: float = 2.0, track_between: bool = True,
        records: Iterable[ScanRecord] | None = None) -> RunResult:
    """SLAM over a log. ``track_between``: also scan-match the skipped scans against the best map
    (better poses for them than odometry; off = pure odometry interpolation). ``records``: the log's,
    already read (``log`` then only names it)."""
    slam: GridSlam | None = None
    stamps: list[float] = []
    odoms: list[Pose2D] = []
    t0 = time.perf_counter()
    c0 = time.process_time()
    last = t0
    update_cpu = 0.0
    for rec in (records if records is not None else read_log(log)):
        if max_scans is not None and len(stamps) >= max_scans:
            break
        if slam is None:  # the laser's place on the base: the log's, when it says (a recording's tf_static)
            slam = GridSlam(params, laser=rec.laser, track_between=track_between)
        stamps.append(rec.stamp)
        odoms.append(rec.odom)
        u0 = time.process_time()
        if slam.process(rec.stamp, rec.odom, rec.scan):
            update_cpu += time.process_time() - u0
        now = time.perf_counter()
        if progress is not None and now - last >= every_s:
            last = now
            data = stamps[-1] - stamps[0]
            progress.write(f"\rscans {len(stamps)} processed {slam.processed} data {data:7.1f} s "
                           f"wall {now - t0:7.1f} s  x{data / (now - t0):5.2f} real time  "
                           f"neff {slam.last_neff:5.1f} resamples {slam.resamples}   ")
            progress.flush()
    wall = time.perf_counter() - t0
    if slam is None:
        raise ValueError(f"{log}: no scans")
    poses = full_trajectory(odoms, slam.trajectory(), slam.between)
    res = RunResult(np.array(stamps), poses, len(stamps), slam.processed, stamps[-1] - stamps[0], wall, slam,
                    time.process_time() - c0, update_cpu)
    if progress is not None:
        progress.write(f"\rscans {res.scans} processed {res.processed} data {res.data_s:.1f} s wall "
                       f"{wall:.1f} s (cpu {res.cpu_s:.1f} s)  x{res.realtime_factor:.2f} real time  "
                       f"{res.update_ms:.1f} ms/update  resamples {slam.resamples}\n")
    return res


def write_outputs(res: RunResult, out: str | Path) -> None:
    """DIR/map.pgm + DIR/map.yaml (map_server format) and DIR/trajectory.txt (stamp x y theta)."""
    d = Path(out)
    d.mkdir(parents=True, exist_ok=True)
    save_map(res.slam.occupancy_grid(float(res.stamps[-1])), d / "map")
    with open(d / "trajectory.txt", "w") as f:
        for t, (x, y, th) in zip(res.stamps, res.poses):
            f.write(f"{t:.6f} {x:.6f} {y:.6f} {th:.6f}\n")
