"""`zenav slam run LOG --method hector`: hector over a log, IGNORING its odometry; progress on stderr;
map.pgm/map.yaml and trajectory.txt as gmapping's runner writes them."""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

import numpy as np

from master_side.hector.params import HectorParams
from master_side.hector.slam import HectorSlam
from master_side.mapping.map_io import save_map
from master_side.slam.logs import read_log


@dataclass
class HectorRun:
    stamps: np.ndarray  # (N,) every scan's stamp
    poses: np.ndarray  # (N, 3) matched pose of every scan
    scans: int
    processed: int  # map updates
    data_s: float
    wall_s: float
    slam: HectorSlam
    cpu_s: float = 0.0

    @property
    def realtime_factor(self) -> float:
        return self.data_s / self.wall_s if self.wall_s > 0 else float("inf")


def run(log: str | Path, params: HectorParams, max_scans: int | None = None,
        progress: TextIO | bool | None = True, every_s: float = 2.0, records=None) -> HectorRun:
    """Every scan of ``log`` (or of ``records``, an iterable of ScanRecord) matched in turn; the
    records' odometry is never read. ``progress``: a stream, True (stderr) or None/False (quiet)."""
    if progress is True:
        progress = sys.stderr
    progress = progress or None
    slam = HectorSlam(params)
    stamps: list[float] = []
    poses: list[np.ndarray] = []
    t0, c0 = time.perf_counter(), time.process_time()
    last = t0
    for rec in (records if records is not None else read_log(log)):
        if max_scans is not None and len(stamps) >= max_scans:
            break
        stamps.append(rec.stamp)
        poses.append(slam.process(rec.stamp, rec.scan).as_array())
        now = time.perf_counter()
        if progress is not None and now - last >= every_s:
            last = now
            data = stamps[-1] - stamps[0]
            progress.write(f"\rscans {len(stamps)} map updates {slam.map_updates} data {data:7.1f} s "
                           f"wall {now - t0:7.1f} s  x{data / (now - t0):5.2f} real time   ")
            progress.flush()
    wall = time.perf_counter() - t0
    if not stamps:
        raise ValueError(f"{log}: no scans")
    res = HectorRun(np.array(stamps), np.array(poses), len(stamps), slam.map_updates, stamps[-1] - stamps[0],
                    wall, slam, time.process_time() - c0)
    if progress is not None:
        progress.write(f"\rscans {res.scans} map updates {res.processed} data {res.data_s:.1f} s wall "
                       f"{wall:.1f} s (cpu {res.cpu_s:.1f} s)  x{res.realtime_factor:.2f} real time\n")
    return res


def write_outputs(res: HectorRun, out: str | Path) -> None:
    """DIR/map.pgm + DIR/map.yaml (map_server format) and DIR/trajectory.txt (stamp x y theta)."""
    d = Path(out)
    d.mkdir(parents=True, exist_ok=True)
    save_map(res.slam.occupancy_grid(float(res.stamps[-1]), crop=True), d / "map")
    with open(d / "trajectory.txt", "w") as f:
        for t, (x, y, th) in zip(res.stamps, res.poses):
            f.write(f"{t:.6f} {x:.6f} {y:.6f} {th:.6f}\n")
