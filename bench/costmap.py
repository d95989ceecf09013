"""Costmap benchmark: local rolling 3 m x 3 m at 0.025 m with a 720-beam scan (full cycle, inflation
included) and the global 50 m x 50 m at 0.1 m fully re-inflated. Run: python bench/costmap.py"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from common.geometry import Pose2D  # noqa: E402
from master_side.costmap.cost_values import LETHAL  # noqa: E402
from master_side.costmap.layered import LayeredCostmap  # noqa: E402
from master_side.costmap.params import load_costmap_config  # noqa: E402

COMMON = {  # the tutorial's costmap_common_params.yaml
    "obstacle_range": 5.0, "raytrace_range": 6.0, "max_obstacle_height": 1.0, "min_obstacle_height": 0.05,
    "footprint": [[0.3302, -0.0508], [0.254, -0.0508], [0.254, -0.254], [-0.254, -0.254], [-0.254, 0.254],
                  [0.254, 0.254], [0.254, 0.0508], [0.3302, 0.0508]],
    "inflation_radius": 0.35, "footprint_padding": 0, "transform_tolerance": 1.0, "map_type": "costmap",
    "cost_scaling_factor": 100, "observation_sources": "laser_scan_sensor",
    "laser_scan_sensor": {"sensor_frame": "camera_link", "data_type": "LaserScan", "topic": "scan",
                          "marking": True, "clearing": True},
}
LOCAL = {"local_costmap": {"global_frame": "/odom", "robot_base_frame": "base_link", "update_frequency": 5.0,
                           "publish_frequency": 10.0, "static_map": False, "rolling_window": True,
                           "width": 3.0, "height": 3.0, "resolution": 0.025}}
GLOBAL = {"global_costmap": {"global_frame": "/map", "robot_base_frame": "base_link", "update_frequency": 1.0,
                             "publish_frequency": 1.0, "static_map": False, "width": 50, "height": 50,
                             "origin_x": -25, "origin_y": -25, "resolution": 0.1}}


def room_scan(x: float, y: float, n: int = 720) -> np.ndarray:
    """A 720-beam scan in a 6 m x 4 m room with a pillar, from (x, y), as global points (N, 3)."""
    a = np.linspace(-np.pi, np.pi, n, endpoint=False)
    c, s = np.cos(a), np.sin(a)
    with np.errstate(divide="ignore"):
        rx = np.abs(np.where(c > 0, 3.0 - x, -3.0 - x) / c)
        r = np.minimum(rx, np.abs(np.where(s > 0, 2.0 - y, -2.0 - y) / s))
    px, py = 1.2 - x, 0.4 - y  # pillar of radius 0.15
    b = px * c + py * s
    disc = b * b - (px * px + py * py - 0.0225)
    hit = (disc > 0) & (b > 0)
    r = np.where(hit, np.minimum(r, b - np.sqrt(np.maximum(disc, 0))), r)
    return np.column_stack((x + r * c, y + r * s, np.full(n, 0.35)))


def stats(ts: list[float]) -> tuple[float, float, float]:
    a = np.array(ts) * 1e3
    return float(np.median(a)), float(np.percentile(a, 90)), float(a.max())


def bench_local(cycles: int = 60) -> list[float]:
    lc = LayeredCostmap.from_config(load_costmap_config(COMMON, LOCAL, "bench"))
    ob = lc.layer("obstacle_layer")
    ts = []
    for i in range(cycles):
        x, y = -1.0 + 0.031 * i, 0.2 * np.sin(0.1 * i)
        pose = Pose2D(x, y, 0.05 * i)
        ob.add_observation("laser_scan_sensor", room_scan(x, y), np.array([x + 0.1, y, 0.35]), 0.2 * i)
        t = time.perf_counter()
        lc.update_map(pose)
        ts.append(time.perf_counter() - t)
    return ts


def bench_global(cycles: int = 8) -> tuple[list[float], list[float]]:
    lc = LayeredCostmap.from_config(load_costmap_config(COMMON, GLOBAL, "bench"))
    ob, inf = lc.layer("obstacle_layer"), lc.layer("inflation_layer")
    rng = np.random.default_rng(1)
    grid = ob.costmap.data
    grid[::40, :] = LETHAL  # walls every 4 m and scattered clutter
    grid[:, ::40] = LETHAL
    grid[rng.integers(0, 500, 3000), rng.integers(0, 500, 3000)] = LETHAL
    full, cycle = [], []
    for _ in range(cycles):
        inf.need_reinflation = True
        t = time.perf_counter()
        lc.update_map(Pose2D(0.0, 0.0, 0.0))  # bounds: the whole map (re-inflation) + the footprint
        cycle.append(time.perf_counter() - t)
        w = lc.master.full_window()
        t = time.perf_counter()
        inf.update_costs(lc.master, w)
        full.append(time.perf_counter() - t)
    return full, cycle


def main() -> None:
    argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter).parse_args()
    local = bench_local()
    inflate, cycle = bench_global()
    print(f"{'case':<44}{'median ms':>10}{'p90 ms':>10}{'max ms':>10}")
    for name, ts in (("local 120x120 @0.025, 720 beams, full cycle", local),
                     ("global 500x500 @0.1, inflation full window", inflate),
                     ("global 500x500 @0.1, full cycle (reset+all)", cycle)):
        print(f"{name:<44}" + "".join(f"{v:>10.2f}" for v in stats(ts)))
    print(f"local_update_ms={stats(local)[0]:.2f} global_inflate_ms={stats(inflate)[0]:.2f}")


if __name__ == "__main__":
    main()
