"""MRPB 1.0 (Wen et al., ICRA 2021): the simulated Pioneer 3-AT with its planar laser crosses the
benchmark's offices, mall, maze, narrow graph, room and track (../shared/datasets/mrpb, every start/goal
test of the static environments, the partially unknown ones included: the robot is given the incomplete
map, the simulator has the full one).

Two modes:
  --mode fast  simulator, costmaps and move_base stepped in one process on the simulated clock, TF exact
               (deploy/mrpb/inproc.py): quick, for iterating.
  --mode bus   the real thing: `zenav robot` and `zenav master` as separate processes on a private loopback
               Zenoh network, localised by AMCL on the given map from the case's start, the goal sent as
               `zenav goal` sends it (deploy/mrpb/bus.py).

Two master configurations (--configs): `tutorial` (the reference tutorial's P3-AT files as printed:
p3at_amcl.yaml over the bus, p3at_known_map.yaml in the fast mode) and `zenav` (p3at_zenav.yaml).

A run succeeds when move_base reaches the goal (the tutorial's 0.3 m) with no contact; it ends at the first
contact, when move_base gives up, or after 300 s of simulated time. Metrics as MRPB defines them
(deploy/mrpb/metrics.py): the least and mean distance from the robot's centre to an obstacle of the true
world, the share of time within --safe-distance of one, travel time, path length, path smoothness, mean
|acceleration| (MRPB's velocity smoothness), plus mean |jerk| and |angular acceleration|.

  python bench/mrpb.py --mode bus                       # every case, both configurations (~1 h)
  python bench/mrpb.py --mode fast --envs office02,maze --configs zenav

Prints a row per case, a table per configuration and environment, and the summary line (zenav's
configuration; tutorial_* for the tutorial's)
mrpb_success=… mrpb_collisions=… mrpb_time_mean_s=… mrpb_min_clearance_m=… mrpb_jerk_mean=… …
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from collections import defaultdict
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from deploy.mrpb import metrics as mm  # noqa: E402
from deploy.mrpb.cases import STATIC_ENVS, Case, Result, load_cases  # noqa: E402
from deploy.stack.physics_sets import master_sets, robot_sets  # noqa: E402

DATA = ROOT.parent / "shared" / "datasets" / "mrpb" / "map10cm"
ROBOT = ROOT / "robot_side" / "config" / "p3at_sim_laser.yaml"
CONFIG = ROOT / "master_side" / "config"
MASTERS = {  # (fast mode, bus mode): the fast mode's TF is exact, so it takes the fake_localization file
    "tutorial": (CONFIG / "p3at_known_map.yaml", CONFIG / "p3at_amcl.yaml"),
    "zenav": (CONFIG / "p3at_zenav.yaml", CONFIG / "p3at_zenav.yaml"),
}
# MRPB leaves d_safe to the user: the P3-AT's circumscribed radius (0.36 m, the footprint of the tutorial's
# p3at/costmap_common_params.yaml) + 0.1 m
SAFE_DISTANCE_M = 0.46


# What zenav's configuration changes on an engine: its model of the robot it drives (deploy/stack/physics_sets.py
# says what and why); the tutorial's files stay as ROS has them.
ENGINE_SETS = {("zenav", "mujoco"): master_sets("mujoco", amcl=True)}
ENGINE_ROBOT_SETS = {("zenav", "mujoco"): robot_sets("mujoco")}


def _fast(job: tuple) -> Result:
    case, robot, master, engine, sets, robot_sets = job
    from deploy.mrpb.inproc import run_case_fast

    return run_case_fast(case, robot, master, engine=engine, master_set=sets, robot_set=robot_sets)


def _bus(job: tuple) -> Result:
    case, robot, master, work, speed, engine, sets, robot_sets = job
    from deploy.mrpb.bus import run_case_bus

    return run_case_bus(case, robot, master, work, speed, engine=engine, master_set=sets, robot_set=robot_sets)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    ap.add_argument("--mode", choices=("fast", "bus"), default="fast")
    ap.add_argument("--configs", default="zenav,tutorial", help="comma-separated: zenav, tutorial")
    ap.add_argument("--master", default="", metavar="FILE",
                    help="your own master YAML instead of --configs (both modes; named by its file)")
    ap.add_argument("--envs", default=",".join(STATIC_ENVS), help="comma-separated environments (default: all)")
    ap.add_argument("--tests", default="", help="comma-separated test numbers (default: every test)")
    ap.add_argument("--robot", default=str(ROBOT), help="robot YAML (default: the P3-AT with its planar laser)")
    ap.add_argument("--data", default=str(DATA), help="MRPB's map10cm folder")
    ap.add_argument("--jobs", type=int, default=2, help="cases run at once (fast mode)")
    ap.add_argument("--speed", type=float, default=1.0, help="bus mode: simulated time x real time")
    ap.add_argument("--engine", choices=("kinematic", "mujoco"), default=None,
                    help="simulator engine (default: the robot YAML's, the kinematic one); mujoco: the skid-steered "
                         "P3-AT on rigid-body physics, MRPB's walls as boxes")
    ap.add_argument("--set", action="append", default=[], metavar="NODE.KEY=VALUE",
                    help="one of the master's parameters (zenav master --set), for every configuration")
    ap.add_argument("--safe-distance", type=float, default=SAFE_DISTANCE_M, metavar="M",
                    help=f"MRPB's d_safe (default {SAFE_DISTANCE_M} m)")
    ap.add_argument("--workdir", default="", help="bus mode: where the agents' logs go (default: a temp folder)")
    a = ap.parse_args(argv)
    masters = dict(MASTERS)
    if a.master:
        own = Path(a.master).resolve()
        masters = {own.stem: (own, own)}
    configs = list(masters) if a.master else [c.strip() for c in a.configs.split(",") if c.strip()]
    bad = [c for c in configs if c not in masters]
    if bad:
        ap.error(f"unknown configuration(s) {bad}: choose from {sorted(MASTERS)}")
    try:
        cases = load_cases(Path(a.data), tuple(e.strip() for e in a.envs.split(",") if e.strip()),
                           tuple(int(t) for t in a.tests.split(",") if t.strip()))
    except (FileNotFoundError, ValueError) as e:
        print(f"mrpb: {e}", file=sys.stderr)
        return 2
    work = Path(a.workdir or tempfile.mkdtemp(prefix="zenav-mrpb-"))
    print(f"# MRPB {a.mode} mode: {len(cases)} cases x {len(configs)} configurations, robot {a.robot}"
          f"{f', agents logs in {work}' if a.mode == 'bus' else ''}", flush=True)
    fields = {}
    t0 = time.monotonic()
    results: dict[str, list[tuple[Result, mm.RunMetrics]]] = {}  # each run with its metrics, computed once
    for cfg in configs:
        master = masters[cfg][0 if a.mode == "fast" else 1]
        sets = (*ENGINE_SETS.get((cfg, a.engine), ()), *a.set)
        robot_set = ENGINE_ROBOT_SETS.get((cfg, a.engine), ())
        if a.mode == "fast":  # map -> odom is exact: no localiser runs, so none of its parameters is said to
            sets = tuple(kv for kv in sets if not kv.startswith("localization."))  # apply (odom is the odometry)
        print(f"## {cfg}: {master}{''.join(f' --set {s}' for s in sets)}"
              f"{''.join(f'; robot --set {s}' for s in robot_set)}", flush=True)
        if a.mode == "fast":
            with ProcessPoolExecutor(max_workers=max(1, a.jobs)) as ex:
                runs = ex.map(_fast, [(c, a.robot, master, a.engine, sets, robot_set) for c in cases])
                results[cfg] = list(_progress(runs, cases, fields, a.safe_distance, t0))
        else:
            from deploy.stack.process_group import terminate_as_interrupt

            with terminate_as_interrupt():  # a killed bench stops each case's agents too
                runs = map(_bus, [(c, Path(a.robot), master, work / cfg, a.speed, a.engine, sets, robot_set)
                            for c in cases])
                results[cfg] = list(_progress(runs, cases, fields, a.safe_distance, t0))
    summary = []
    for cfg, runs_of in results.items():
        _table(cfg, runs_of, a.safe_distance)
        summary.append(_summary("mrpb" if cfg == "zenav" else cfg, runs_of))
    print(" ".join(summary) + f" cases={len(cases)} mode={a.mode} engine={a.engine or 'yaml'} "
          f"wall_s={time.monotonic() - t0:.0f}")
    return 0


def _metrics(r: Result, fields: dict, safe: float) -> mm.RunMetrics:
    world = r.case.world_file
    if world not in fields:
        from master_side.mapping.map_io import load_map

        fields[world] = mm.DistanceField.of(load_map(world))
    return mm.compute(r.trace, fields[world], safe)


def _progress(runs, cases: list[Case], fields: dict, safe: float, t0: float):
    """Each run with its metrics, printed as it ends."""
    for i, r in enumerate(runs, 1):
        m = _metrics(r, fields, safe)
        note = f"  {r.reason}" if r.reason else ""
        loc = (f"  AMCL err p95 {np.percentile(r.loc_err, 95):.2f} m" if r.loc_err is not None and len(r.loc_err)
               else "")
        print(f"[{i:2d}/{len(cases)}] {r.case.name:34s} {r.status:9s} {m.time_s:6.1f} s {m.path_m:5.1f} m  "
              f"d_min {m.d_min_m:.2f} m{loc}  ({time.monotonic() - t0:.0f} s){note}", flush=True)
        yield r, m


def _table(cfg: str, rs: list[tuple[Result, mm.RunMetrics]], safe: float) -> None:
    print(f"\n{cfg}: successes' means (time, path, distances, smoothness); d_min is the least of all runs")
    print("| environment | cases | success | collisions | time (s) | path (m) | d_min (m) | d_mean (m) | "
          f"time within {safe:g} m (%) | |accel| (m/s²) | |jerk| (m/s³) | |ang. accel| (rad/s²) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    by_env: dict[str, list[tuple[Result, mm.RunMetrics]]] = defaultdict(list)
    for r, m in rs:
        by_env[r.case.env].append((r, m))
    for env, group in [*by_env.items(), ("all", rs)]:
        ok = [m for r, m in group if r.success]
        mins = [m.d_min_m for r, m in group if len(r.trace) > 1]

        def mean(attr: str, ok=ok) -> str:
            return f"{np.mean([getattr(m, attr) for m in ok]):.2f}" if ok else "-"
        print(f"| {env} | {len(group)} | {sum(r.success for r, _ in group)} | "
              f"{sum(r.status == 'collision' for r, _ in group)} | {mean('time_s')} | {mean('path_m')} | "
              f"{min(mins):.2f} | {mean('d_mean_m')} | {mean('danger_pct')} | {mean('accel_mean')} | "
              f"{mean('jerk_mean')} | {mean('ang_accel_mean')} |" if mins else f"| {env} | {len(group)} | 0 | - |")


def _summary(prefix: str, runs_of: list[tuple[Result, mm.RunMetrics]]) -> str:
    rs = [r for r, _ in runs_of]
    ok = [m for r, m in runs_of if r.success]
    mins = [m.d_min_m for r, m in runs_of if len(r.trace) > 1]
    nan = math.nan
    errs = [r.loc_err for r in rs if r.loc_err is not None and len(r.loc_err)]
    loc = f" {prefix}_loc_err_p95_m={np.percentile(np.concatenate(errs), 95):.3f}" if errs else ""
    return (f"{prefix}_success={sum(r.success for r in rs) / max(1, len(rs)):.3f} "
            f"{prefix}_collisions={sum(r.status == 'collision' for r in rs)} "
            f"{prefix}_time_mean_s={np.mean([m.time_s for m in ok]) if ok else nan:.1f} "
            f"{prefix}_min_clearance_m={min(mins) if mins else nan:.2f} "
            f"{prefix}_jerk_mean={np.mean([m.jerk_mean for m in ok]) if ok else nan:.3f} "
            f"{prefix}_danger_pct={np.mean([m.danger_pct for m in ok]) if ok else nan:.1f}{loc}")


if __name__ == "__main__":
    raise SystemExit(main())
