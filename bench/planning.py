"""Planner benchmark: navfn on the Moving AI maps, DWA cycle time on a P3-AT local costmap.

navfn: every .map/.scen pair under shared/datasets/movingai (obstacles LETHAL, free FREE, 1 cell = 1 m),
a few queries from evenly spread buckets; time per query and path length / octile optimum (a
Euclidean-ish planner should come out <= 1). DWA: the p3at dwa_planner_ros.yaml with vx 20 x vth 20
samples on a 3 m x 3 m, 0.025 m costmap with inflated boxes, the robot advancing along the plan
(flood fills are reused while the costmap and the pruned plan stay the same, as in a real run between
costmap updates; dwa_cold_ms: with new fills every cycle). Run: python bench/planning.py
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np
from scipy import ndimage

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from common.config import load_params, read_yaml  # noqa: E402
from common.geometry import Pose2D  # noqa: E402
from master_side.planning.grid import INSCRIBED, LETHAL  # noqa: E402
from master_side.planning.local import DWAPlanner, DWAPlannerParams  # noqa: E402
from master_side.planning.local.scoring_context import forget_recent_fills  # noqa: E402
from master_side.planning.navfn import NavFn, path_length  # noqa: E402

SHARED = Path(os.environ.get("ZENAV_SHARED", REPO.parent / "shared"))
P3AT_FOOTPRINT = np.array(
    [
        [0.3302, -0.0508],
        [0.254, -0.0508],
        [0.254, -0.254],
        [-0.254, -0.254],
        [-0.254, 0.254],
        [0.254, 0.254],
        [0.254, 0.0508],
        [0.3302, 0.0508],
    ]
)


def read_map(path: Path) -> np.ndarray:
    """Moving AI .map -> uint8 costmap (row = map line y), '.', 'G', 'S' free, the rest LETHAL."""
    lines = path.read_text().splitlines()
    h = int(lines[1].split()[1])
    w = int(lines[2].split()[1])
    rows = lines[4 : 4 + h]
    free = np.array([[ch in ".GS" for ch in r[:w]] for r in rows])
    return np.where(free, 0, LETHAL).astype(np.uint8)


def read_scen(path: Path) -> list[tuple[int, int, int, int, int, float]]:
    out = []
    for line in path.read_text().splitlines()[1:]:
        f = line.split()
        if len(f) >= 9:
            out.append((int(f[0]), int(f[4]), int(f[5]), int(f[6]), int(f[7]), float(f[8])))
    return out


def pick(scen: list, per_map: int, rng: np.random.Generator) -> list:
    """``per_map`` queries from buckets spread evenly over the file's range (longest bucket included)."""
    buckets = sorted({s[0] for s in scen})
    chosen = [buckets[int(round(i))] for i in np.linspace(0, len(buckets) - 1, min(per_map, len(buckets)))]
    out = []
    for b in chosen:
        cands = [s for s in scen if s[0] == b]
        out.append(cands[int(rng.integers(len(cands)))])
    return out


def bench_navfn(per_map: int) -> tuple[list[dict], list[float], list[float], list[float]]:
    rng = np.random.default_rng(1)
    rows, t256, c256, ratios = [], [], [], []
    nf = NavFn()
    for scen_path in sorted((SHARED / "datasets" / "movingai").rglob("*.scen")):
        name = scen_path.name.replace("-random-1.scen", ".map").replace(".map.scen", ".map")
        map_path = scen_path.parent / name
        if not map_path.exists():
            continue
        grid = read_map(map_path)
        times, cpu, rat = [], [], []
        for _, sx, sy, gx, gy, opt in pick(read_scen(scen_path), per_map, rng):
            t0, c0 = time.perf_counter(), time.process_time()
            path = nf.make_plan(grid, 1.0, (0.0, 0.0), Pose2D(sx + 0.5, sy + 0.5), Pose2D(gx + 0.5, gy + 0.5))
            times.append(time.perf_counter() - t0)
            cpu.append(time.process_time() - c0)
            if opt > 0:
                rat.append(path_length(path) / opt)
        is256 = grid.shape == (256, 256)
        if is256:
            t256 += times
            c256 += cpu
        ratios += rat
        rows.append(
            {
                "map": map_path.stem,
                "size": f"{grid.shape[1]}x{grid.shape[0]}",
                "n": len(times),
                "med_ms": 1e3 * float(np.median(times)),
                "max_ms": 1e3 * max(times),
                # a query with start = goal has no optimum to compare with (--per-map 1 may draw only that)
                "ratio_med": float(np.median(rat)) if rat else float("nan"),
                "ratio_max": max(rat, default=float("nan")),
                "ratio_min": min(rat, default=float("nan")),
            }
        )
    return rows, t256, c256, ratios


def local_costmap() -> np.ndarray:
    """3 m x 3 m at 0.025 m: two boxes and a wall, inflated like costmap_2d (inscribed 0.254 m)."""
    res = 0.025
    g = np.zeros((120, 120), np.uint8)
    g[80:90, 70:80] = LETHAL
    g[20:35, 85:95] = LETHAL
    g[100:104, 0:60] = LETHAL
    d = ndimage.distance_transform_edt(g < LETHAL) * res
    infl = np.where(d <= 0.254, INSCRIBED, np.where(d <= 0.35, 252 * np.exp(-10 * (d - 0.254)), 0))
    return np.maximum(g, infl.astype(np.uint8))


def bench_dwa(cycles: int, cold: bool = False) -> tuple[float, float, int]:
    """Median wall / CPU ms per cycle. ``cold``: forget the flood fills before every cycle (as if the
    costmap or the plan were new each time; otherwise a fill is reused while both stay the same)."""
    path = SHARED / "reference" / "p3at" / "dwa_planner_ros.yaml"
    cfg = read_yaml(path)["DWAPlannerROS"]
    params = load_params(
        DWAPlannerParams,
        {**cfg, "vx_samples": 20, "vth_samples": 20, "controller_frequency": 10.0},
        source=str(path),
    )
    planner = DWAPlanner(params)
    grid = local_costmap()
    xs = np.linspace(0.3, 2.9, 60)
    planner.set_plan(np.column_stack((xs, 1.5 + 0.3 * np.sin(xs), np.zeros_like(xs))))
    forget_recent_fills()
    times, cpu, n = [], [], 0
    for k in range(cycles):
        pose = Pose2D(0.4 + 0.6 * k / max(cycles - 1, 1), 1.5, 0.1)
        if cold:
            forget_recent_fills()
        t0, c0 = time.perf_counter(), time.process_time()
        res = planner.compute_velocity(pose, (0.3, 0.0, 0.2), grid, 0.025, (0.0, 0.0), P3AT_FOOTPRINT)
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
        n = res.n_samples
    return 1e3 * float(np.median(times)), 1e3 * float(np.median(cpu)), n


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--per-map", type=int, default=24, help="queries per Moving AI map")
    ap.add_argument("--dwa-cycles", type=int, default=60)
    a = ap.parse_args()
    rows, t256, c256, ratios = bench_navfn(a.per_map)
    print(f"{'map':<22}{'size':>9}{'n':>4}{'med ms':>9}{'max ms':>9}{'len/opt med':>13}{'min':>7}{'max':>7}")
    for r in rows:
        print(
            f"{r['map']:<22}{r['size']:>9}{r['n']:>4}{r['med_ms']:>9.1f}{r['max_ms']:>9.1f}"
            f"{r['ratio_med']:>13.4f}{r['ratio_min']:>7.3f}{r['ratio_max']:>7.4f}"
        )
    dwa_ms, dwa_cpu_ms, dwa_n = bench_dwa(a.dwa_cycles)
    cold_ms, cold_cpu_ms, _ = bench_dwa(a.dwa_cycles, cold=True)
    print(
        f"\nnavfn 256x256: median {1e3 * np.median(t256):.1f} ms (CPU {1e3 * np.median(c256):.1f} ms) over "
        f"{len(t256)} queries; "
        f"length/octile optimum: median {np.median(ratios):.4f}, max {max(ratios):.4f} "
        f"({len(ratios)} queries)"
    )
    print(
        f"DWA (p3at params, 20 x 20 samples, 120x120 @ 0.025 m): median {dwa_ms:.2f} ms/cycle "
        f"(CPU {dwa_cpu_ms:.2f} ms), {dwa_n} samples; with new flood fills every cycle {cold_ms:.2f} ms "
        f"(CPU {cold_cpu_ms:.2f} ms)"
    )
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs (wall times inflate under load)")
    print(
        f"navfn_256_ms={1e3 * np.median(t256):.1f} navfn_len_ratio={max(ratios):.4f} "
        f"dwa_cycle_ms={dwa_ms:.2f} dwa_samples={dwa_n} dwa_cold_ms={cold_ms:.2f} "
        f"navfn_256_cpu_ms={1e3 * np.median(c256):.1f} dwa_cycle_cpu_ms={dwa_cpu_ms:.2f}"
    )


if __name__ == "__main__":
    main()
