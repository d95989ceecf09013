"""SLAM replayed on a recorded exploration: the same scans and odometry mapped again offline with other
gmapping parameters, each map judged against the world the simulator drove in.

An exploration's map is one draw of a closed loop: where the robot went depended on the map it had. To
compare SLAM's parameters on the same data, record a run (`python bench/explore.py --record ...`: its
`run.mcap` holds scan, odom, tf_static and the simulator's ground truth) and replay it here, in this
process (master_side.slam.offline, as `zenav slam run` does; no bus, as fast as the filter goes).

Per variant: the map's walls within two cells of a true wall and its free cells on true free space, judged
where the map fits best on the world (bench/explore.py's figures; the fitted turn and shift beside them),
the share of the reachable free area it knows, and the trajectory's distance from the ground truth at each
scan (in the fitted frame): mean, p95, max; then the heading's short-term error (less its 20 s running
median) in bands of the true turn rate, the wheel odometry's beside them: a narrow view that loses the
heading in turns shows as the faster bands growing, no better than the odometry; and update by update, along
the final map's lineage, the p95 error of each filter update's heading step beside the odometry's over the
same interval, in bands of the true step (the matcher itself, no whole-map turn). Variants are `KEY=VALUE ...`
strings of slam_gmapping parameters over the master file's (p3at_slam_zenav.yaml's: the tutorial's
gmapping.yaml, 30 particles).

  python bench/slam_replay.py RUN_DIR --world shopping_mall
  python bench/slam_replay.py RUN_DIR --world shopping_mall --variant "" --variant "maxUrange=30" \\
      --variant "maxUrange=30 particles=100"

`--seeds N` replays each variant with gmapping's seeds 0..N-1 and adds each variant's mean, min and max.
`--live` (a run recorded since the exploration bench saves `slam_trajectory.txt`) adds the live SLAM node's
own row, its saved map and trajectory judged the same way, and replays only the scans the live node mapped:
a live run that differs from its replay is then either in those scans (a filter that fell behind) or not.

`--gyro K` replays the run as a P3-AT with its optional gyro would have reported it (the simulator's
`base.gyro`): each odometry step keeps the wheels' translation, and its heading step becomes the ground
truth's times (1 + K) plus the gyro's noise (ARIA's figures, `robot_side/sim/base_params.py`). K is the gyro's
scale error: ARIA's default scaling is within 0.03 of correct; a calibrated gyro does better.

Ends with slam_replay_variants=… slam_replay_seeds=… slam_replay_walls_pct=… (the first variant's, its mean
over the seeds) slam_replay_traj_p95_m=… slam_replay_best=… (the variant with the most walls right)
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from deploy.logs.mcap_io import read_records  # noqa: E402
from deploy.stack.map_check import FIT_HEADINGS_DEG, WorldTruth  # noqa: E402
from deploy.stack.png import write_png  # noqa: E402
from master_side.slam import node as slam_node  # noqa: E402
from master_side.slam.logs import scan_records  # noqa: E402
from master_side.slam.offline import run, write_outputs  # noqa: E402
from robot_side.sim.world import is_map_world  # noqa: E402

MASTER = ROOT / "master_side/config/p3at_slam_zenav.yaml"


def gmapping_params(master: Path, variant: str):
    """slam_gmapping's parameters as `zenav master --config master --set slam_gmapping.KEY=VALUE ...` gives
    them, one assignment per ``KEY=VALUE`` of ``variant``."""
    return slam_node.master_params(str(master), sets=tuple(f"slam_gmapping.{kv}" for kv in variant.split()))


def _interp(ts: np.ndarray, xy: np.ndarray, t: np.ndarray) -> np.ndarray:
    return np.column_stack([np.interp(t, ts, xy[:, k]) for k in range(xy.shape[1])])


TURN_BANDS = ((0.0, 0.05), (0.05, 0.3), (0.3, 0.6), (0.6, math.inf))  # rad/s, the true turn rate


def _heading_by_turn(stamps: np.ndarray, theta: np.ndarray, gt_t: np.ndarray, gt_th: np.ndarray) -> list[float]:
    """Mean short-term heading error (deg) of a trajectory, in bands of the true turn rate (TURN_BANDS): each
    scan's heading error less its running median over 20 s, so a map turned as a whole does not count, only
    the filter losing the heading for a while. A narrow view that loses it in turns shows as the faster bands
    growing."""
    from scipy.ndimage import median_filter

    if len(gt_t) < 2 or len(stamps) < 3:
        return [math.nan] * len(TURN_BANDS)
    th = np.unwrap(gt_th)
    rate = np.abs(np.interp(stamps, gt_t, np.gradient(th, gt_t)))
    err = np.unwrap(theta) - np.interp(stamps, gt_t, th)
    window = int(20.0 / max(float(np.median(np.diff(stamps))), 1e-3)) | 1
    err = np.degrees(np.abs(err - median_filter(err, size=window, mode="nearest")))
    return [float(err[m].mean()) if (m := (rate >= lo) & (rate < hi)).any() else math.nan for lo, hi in TURN_BANDS]


STEP_BANDS = ((0.0, 0.05), (0.05, 0.15), (0.15, math.inf))  # rad, the true turn between two filter updates


def _update_steps(stamps: np.ndarray, theta: np.ndarray, gt_t: np.ndarray, gt_th: np.ndarray,
                  odom_t: np.ndarray, odom_th: np.ndarray) -> list[tuple[float, float, int]]:
    """Per band of the true turn between consecutive filter updates (STEP_BANDS): the p95 |error| (deg) of
    each update's heading step along the final map's lineage (``stamps``, ``theta``: its updates), the
    wheel odometry's over the same intervals, and the count. Whole-map turns cancel out; a matcher that
    steps worse than the odometry it started from shows here, update by update."""
    if len(stamps) < 2 or len(gt_t) < 2 or len(odom_t) < 2:
        return [(math.nan, math.nan, 0)] * len(STEP_BANDS)
    true = np.diff(np.interp(stamps, gt_t, np.unwrap(gt_th)))
    odom = np.diff(np.interp(stamps, odom_t, np.unwrap(odom_th)))
    est = np.diff(np.unwrap(theta))
    out = []
    for lo, hi in STEP_BANDS:
        m = (np.abs(true) >= lo) & (np.abs(true) < hi)
        out.append((float(np.degrees(np.percentile(np.abs(est[m] - true[m]), 95))),
                    float(np.degrees(np.percentile(np.abs(odom[m] - true[m]), 95))), int(m.sum()))
                   if m.any() else (math.nan, math.nan, 0))
    return out


def with_gyro_heading(messages: list, scale_error: float, seed: int = 0) -> list:
    """``messages`` (topic, message) with each ``odom`` message's heading from a simulated gyro: the wheels'
    step in the base frame, the true heading step (``ground_truth``) x (1 + scale_error) plus the noise of
    ``BaseParams.gyro_noise`` (while moving) and ``gyro_turn_noise``."""
    import dataclasses

    from common.geometry import Pose2D
    from robot_side.sim.base_params import BaseParams

    p = BaseParams()
    gt = [(m.header.stamp, m.pose2d.theta) for t, m in messages if t == "ground_truth"]
    gt_t, gt_th = np.array([s for s, _ in gt]), np.unwrap(np.array([th for _, th in gt]))
    rng = np.random.default_rng(seed)
    out, last, pose = [], None, None
    for topic, m in messages:
        if topic == "odom":
            wheels, t = m.pose2d, m.header.stamp
            if last is None:
                pose = wheels
            else:
                step = last[1].between(wheels)
                dth = float(np.interp(t, gt_t, gt_th) - np.interp(last[0], gt_t, gt_th))
                moving = abs(dth) > 1e-9 or math.hypot(step.x, step.y) > 1e-9
                var = (p.gyro_noise ** 2 * (t - last[0]) if moving else 0.0) + p.gyro_turn_noise ** 2 * abs(dth)
                gyro = (1 + scale_error) * dth + math.sqrt(var) * float(rng.standard_normal())
                pose = pose.compose(Pose2D(step.x, step.y, gyro))
            last = (t, wheels)
            m = dataclasses.replace(m, pose=pose.to_transform())
        out.append((topic, m))
    return out


def _judge(grid, stamps: np.ndarray, poses: np.ndarray, truth, start, gt_t: np.ndarray, gt_xy: np.ndarray,
           gt_th: np.ndarray):
    """(walls, free, known, the map frame's fitted offset, trajectory error per scan, heading error by turn
    rate) of a map and its trajectory, the map laid where it fits on the world."""
    offset = truth.fit(grid, headings_deg=FIT_HEADINGS_DEG)
    fitted = truth.moved(offset)
    walls, free = fitted.agreement(grid)
    est = start.compose(offset).apply(poses[:, :2])  # the map's frame in the world
    err = np.hypot(*(est - _interp(gt_t, gt_xy, stamps)).T) if len(gt_t) else np.full(len(est), np.nan)
    turn = _heading_by_turn(stamps, poses[:, 2] + start.theta + offset.theta, gt_t, gt_th)
    return walls, free, fitted.explored(grid), offset, err, turn


def _live_row(run_dir: Path, gt_t: np.ndarray, gt_xy: np.ndarray, gt_th: np.ndarray, truth, start):
    """The live SLAM's stamps and its row: its saved map and its trajectory judged as a replay's."""
    from types import SimpleNamespace

    from master_side.mapping.map_io import load_map
    from master_side.slam.evaluate import read_trajectory

    stamps, poses = read_trajectory(run_dir / "slam_trajectory.txt")
    judged = _judge(load_map(run_dir / "explored.yaml"), stamps, poses, truth, start, gt_t, gt_xy, gt_th)
    res = SimpleNamespace(scans=len(stamps), processed=0, update_ms=float("nan"))
    return stamps, ("live (online)", res, *judged, 0.0, None)


def main(argv: list[str] | None = None) -> int:
    from bench.explore import world_and_start

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], epilog=__doc__.split("\n\n", 1)[1],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("run", help="a run directory of bench/explore.py --record, or its run.mcap")
    ap.add_argument("--world", required=True, help="the world it drove in (room, office02, shopping_mall)")
    ap.add_argument("--variant", action="append", default=None, metavar="'KEY=VALUE ...'",
                    help="slam_gmapping parameters over the master file's (repeatable; default: the file's own)")
    ap.add_argument("--master", default=str(MASTER), help="the master file whose slam_gmapping is replayed")
    ap.add_argument("--max-scans", type=int, default=None, help="map only the first N scans")
    ap.add_argument("--seeds", type=int, default=1, metavar="N",
                    help="replay each variant with gmapping's seeds 0..N-1 (a particle filter's single draw differs "
                         "by a few percent from the next: compare variants on their means)")
    ap.add_argument("--save", default="", metavar="DIR",
                    help="write each variant's map and trajectory there (zenav slam run's files, a folder each), "
                         "and walls.png: the map laid on the world, its walls right (black) or wrong (red)")
    ap.add_argument("--live", action="store_true",
                    help="judge the live SLAM's map and trajectory (explored.yaml, slam_trajectory.txt of the run "
                         "directory) beside the replays, and replay only the scans the live node mapped")
    ap.add_argument("--gyro", type=float, default=None, metavar="K",
                    help="the odometry's heading from a simulated gyro of scale error K (0.03: ARIA's default "
                         "scaling; 0: exact), the wheels' translation kept")
    a = ap.parse_args(argv)
    path = Path(a.run)
    if path.is_dir() and not (path / "run.mcap").exists():  # bench/explore.py's --record DIR: a run per folder
        found = sorted(path.glob("*/run.mcap"))
        if len(found) != 1:
            ap.error(f"{path}: no run.mcap" + (f"; it holds {len(found)} runs, name one: "
                                                + ", ".join(str(r.parent) for r in found) if found else ""))
        path = found[0].parent
    path = path / "run.mcap" if path.is_dir() else path
    variants = a.variant if a.variant is not None else [""]
    world, start = world_and_start(a.world)

    print(f"reading {path} ...", file=sys.stderr, flush=True)
    messages = [(r.topic, r.msg) for r in read_records(path)]
    if a.gyro is not None:
        messages = with_gyro_heading(messages, a.gyro)
    gt = [(m.header.stamp, m.pose2d) for t, m in messages if t == "ground_truth"]
    gt_t = np.array([s for s, _ in gt])
    gt_xy = np.array([(p.x, p.y) for _, p in gt])
    gt_th = np.array([p.theta for _, p in gt])
    truth = WorldTruth.of(world, start, 0.05, edge_walls=is_map_world(world))  # as the exploration bench
    if a.seeds < 1:
        ap.error(f"--seeds: {a.seeds}: at least 1")
    odom = np.array([(m.header.stamp, m.pose2d.theta) for t, m in messages if t == "odom"]).reshape(-1, 2)
    rows = []
    steps: dict[str, list[tuple[float, float, int]]] = {}
    live: set[float] | None = None
    if a.live:
        if not (path.parent / "slam_trajectory.txt").exists() or not (path.parent / "explored.yaml").exists():
            ap.error(f"--live: {path.parent} lacks slam_trajectory.txt or explored.yaml (the exploration bench "
                     "writes them since 2026-11-30)")
        stamps, row = _live_row(path.parent, gt_t, gt_xy, gt_th, truth, start)
        live = set(np.round(stamps, 4).tolist())
        rows.append(row)
    runs = [(v, f"{v} seed={k}".strip() if a.seeds > 1 else v) for v in variants for k in range(a.seeds)]
    for variant, v in runs:
        params = gmapping_params(Path(a.master), v)
        t0 = time.monotonic()
        print(f"variant {v or 'as-configured'!r} ...", file=sys.stderr, flush=True)
        records = scan_records(iter(messages), str(path))
        if live is not None:
            records = (r for r in records if round(r.stamp, 4) in live)
        res = run(path, params, a.max_scans, progress=None, records=records)
        grid = res.slam.occupancy_grid(float(res.stamps[-1]))
        judged = _judge(grid, res.stamps, res.poses, truth, start, gt_t, gt_xy, gt_th)
        if a.save:
            folder = Path(a.save) / (v.replace(" ", "_").replace("=", "") or "as-configured")
            write_outputs(res, folder)
            write_png(folder / "walls.png", truth.moved(judged[3]).picture(grid))
        lineage = res.slam.trajectory()  # the final map's updates
        steps[v or "as-configured"] = _update_steps(res.stamps[[i for i, _ in lineage]],
                                                    np.array([q.theta for _, q in lineage]), gt_t, gt_th,
                                                    odom[:, 0], odom[:, 1])
        rows.append((v or "as-configured", res, *judged, time.monotonic() - t0, variant))
    print(f"{'variant':34} {'scans':>6} {'upd':>5} {'ms/upd':>7} {'walls%':>6} {'free%':>6} {'known%':>6} "
          f"{'map frame':>13} {'traj mean':>9} {'p95 m':>6} {'max m':>6} {'wall s':>7}")
    for name, res, walls, free, known, off, err, _, wall, _ in rows:
        fit = f"{math.degrees(off.theta):+.1f}°{math.hypot(off.x, off.y):.2f}m"
        print(f"{name:34.34} {res.scans:6d} {res.processed:5d} {res.update_ms:7.1f} {100 * walls:6.1f} "
              f"{100 * free:6.1f} {100 * known:6.1f} {fit:>13} {np.mean(err):9.3f} {np.percentile(err, 95):6.3f} "
              f"{np.max(err):6.3f} {wall:7.0f}")
    bands = " ".join(f"{f'{lo:g}-{hi:g}':>8}" for lo, hi in TURN_BANDS)
    print(f"\n{'heading error, short-term, mean |deg|, by turn rate (rad/s):':60} {bands}")
    named = [(name, turn) for name, *_, turn, _, _ in rows]
    named.append(("the wheel odometry (what SLAM starts from)", _heading_by_turn(odom[:, 0], odom[:, 1], gt_t, gt_th)))
    for name, turn in named:
        print(f"{name:60.60} " + " ".join(f"{x:8.2f}" for x in turn))
    bands = " ".join(f"{f'{lo:g}-{hi:g}':>16}" for lo, hi in STEP_BANDS)
    print(f"\n{'heading step per update, p95 |deg|: replay / odometry (updates)':60} {bands}")
    for name, st in steps.items():
        print(f"{name:60.60} " + " ".join(f"{f'{e:.2f} / {o:.2f} ({n})':>16}" for e, o, n in st))
    by = {v: [r for r in rows if r[9] == v] for v in variants}  # each variant's replays (one per seed)
    walls_mean = {v: float(np.mean([r[2] for r in rs])) for v, rs in by.items()}
    if a.seeds > 1:
        print(f"\n{'variant':34} {'seeds':>5} {'walls% mean':>11} {'min':>6} {'max':>6} {'traj p95 mean m':>15}")
        for v, rs in by.items():
            w = [100 * r[2] for r in rs]
            print(f"{v or 'as-configured':34.34} {len(rs):5d} {np.mean(w):11.1f} {min(w):6.1f} {max(w):6.1f} "
                  f"{np.mean([np.percentile(r[6], 95) for r in rs]):15.3f}")
    first = by[variants[0]]
    best = max(variants, key=lambda v: walls_mean[v])
    print(f"slam_replay_variants={len(variants)} slam_replay_seeds={a.seeds} "
          f"slam_replay_walls_pct={100 * walls_mean[variants[0]]:.1f} "
          f"slam_replay_traj_p95_m={np.mean([np.percentile(r[6], 95) for r in first]):.3f} "
          f"slam_replay_best={(best or 'as-configured').replace(' ', ',')}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

