"""Load (or compile) the SLAM filter's numba kernels before the first scan is matched.

The first scan match of a process loads a dozen kernels from numba's on-disk cache (0.7-1.0 s on an idle
machine, more under load) or compiles them (about 12 s with a cold cache). Inside the filter's first
update that stall is a gap in the scans: the queue keeps only the newest (``scan_queue_size``), so the
update after it integrates all the motion of the stall at once (20 s of the room demo's loop, 3.4 m and
a half turn, measured), the motion model spreads the particles over metres, and a symmetric room is
matched wrongly (the room demo's test failed in 4 of 9 cold-cache runs: 40-87 % of the walls within two
cells, or too few wall cells). The slam_gmapping node calls ``warm_filter`` before it subscribes to the
scans, as move_base warms its planners (``master_side.planning.warmup``); ``deploy.warm_kernels`` calls
it at install time to fill the cache.
"""

from __future__ import annotations

import math

import numpy as np

from common.geometry import Pose2D
from common.messages import LaserScan


def room_scan(x: float, y: float, th: float, n: int = 181) -> LaserScan:
    """A 180-degree scan from (x, y, th) inside a 6 m x 6 m box room centred on the origin."""
    ang = th + np.linspace(-math.pi / 2, math.pi / 2, n)
    c, s = np.cos(ang), np.sin(ang)
    with np.errstate(divide="ignore", invalid="ignore"):
        tx = np.where(c > 0, (3.0 - x) / c, np.where(c < 0, (-3.0 - x) / c, np.inf))
        ty = np.where(s > 0, (3.0 - y) / s, np.where(s < 0, (-3.0 - y) / s, np.inf))
    return LaserScan(angle_min=-math.pi / 2, angle_max=math.pi / 2, angle_increment=math.pi / (n - 1),
                     range_min=0.1, range_max=30.0, ranges=np.minimum(tx, ty).astype(np.float32))


def warm_filter() -> None:
    """A few real updates of a small filter (every kernel of an update and of the map's rendering)."""
    from master_side.slam.gridslam import GridSlam
    from master_side.slam.params import load_gmapping

    slam = GridSlam(load_gmapping(particles=4))
    for k in range(8):
        x, th = -1.0 + 0.3 * k, 0.1 * k
        slam.process(float(k), Pose2D(x, 0.2, th), room_scan(x, 0.2, th))
    slam.occupancy_grid()
