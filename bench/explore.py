"""Exploration benchmark: `zenav explore` maps a building by itself, from an unknown start.

The simulated P3-AT (its planar laser, p3at_sim_laser.yaml, or its Kinect, p3at_sim.yaml) with gmapping
while navigating (p3at_slam_zenav.yaml: the tutorial's p3at_slam.yaml with zenav's local costmap and
DWA), `zenav explore` with its defaults, on a private loopback Zenoh network (deploy/mrpb/exploration.py).
Worlds: `room` (robot_side/worlds/room.yaml, from its start) and MRPB's office02 and shopping_mall
(../shared/datasets/mrpb/maps, from the start of the environment's first test).

Per run: the share of the free area the robot can reach that the map knows as free, over the simulated
time, and the time to 95 % of it; the distance driven; contacts; at the end the map's agreement with the
world (its walls within two cells of a true wall, its free cells on true free space: the lower of the two
is the figure); how it ended (explore says nothing is left, or the time limit). Every map is judged laid
on the world where it fits best ("map frame": the fitted turn and shift of SLAM's frame from the start,
which SLAM knows only as well as its first metres of odometry); "raw" columns judge it at the start.
Each run's folder under --out keeps the map and walls.png: the map laid on the world where it fits, its walls
black where right and red where wrong, the true walls light blue.

  python bench/explore.py                                   # room, office02, mall; laser and Kinect
  python bench/explore.py --worlds room --sensors laser --runs 3
  python bench/explore.py --worlds office02 --sensors laser --engine mujoco   # the P3-AT on physics

Ends with explore_runs=… explore_coverage_pct=… (the least over the runs) explore_time_95_s=… (the mean of
the runs that got there) explore_path_m=… explore_map_agreement_pct=… (the least)
explore_map_walls_unfitted_pct=… (the least, at the start's frame) explore_collisions=… explore_ended_by_itself=…
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from common.geometry import Pose2D  # noqa: E402
from deploy.mrpb.cases import load_cases, world_map  # noqa: E402
from deploy.mrpb.exploration import INTERRUPTED, ExploreRun, run_exploration  # noqa: E402
from deploy.stack.physics_sets import master_sets, robot_sets  # noqa: E402
from deploy.stack.process_group import set_options, terminate_as_interrupt  # noqa: E402
from deploy.stack.sensor_sets import slam_sensor_sets  # noqa: E402

MRPB = ROOT.parent / "shared" / "datasets" / "mrpb" / "map10cm"
ROBOTS = {"laser": ROOT / "robot_side/config/p3at_sim_laser.yaml", "kinect": ROOT / "robot_side/config/p3at_sim.yaml"}
MASTER = ROOT / "master_side/config/p3at_slam_zenav.yaml"
WORLDS = ("room", "office02", "shopping_mall")
RECORDED = ("scan", "odom", "tf_static", "ground_truth", "collision")  # --record: what SLAM and a judge need


def world_and_start(world: str) -> tuple[str, Pose2D]:
    if world == "room":
        return "room", Pose2D(-2.2, 0.0, 0.0)  # robot_side/worlds/room.yaml's start
    case = load_cases(MRPB, (world,), (1,))[0]
    return str(world_map(MRPB, world)), Pose2D(*case.start)


def _known(mark_m: float | None) -> str:
    """Did the local costmap hold the wall the robot touched? (a mark within two of its 0.025 m cells)"""
    if mark_m is None:
        return "no local costmap yet"
    return (f"the local costmap had it, nearest mark {100 * mark_m:.0f} cm" if mark_m <= 0.05 else
            f"not in the local costmap: nearest mark {100 * mark_m:.0f} cm")


def row(r: ExploreRun) -> str:
    t95 = r.time_to(0.95)
    fit = f"{math.degrees(r.offset.theta):+.1f}°{math.hypot(r.offset.x, r.offset.y):.2f}m"
    return (f"{r.name:24} {r.end:11.11} {100 * r.final_share:6.1f} {t95:8.0f} {r.sim_s:7.0f} {r.path_m:7.1f} "
            f"{100 * r.walls_ok:6.1f} {100 * r.free_ok:6.1f} {r.collisions:4d} {r.free_m2:7.0f} {r.wall_s:7.0f} "
            f"{fit:>12} {100 * r.raw_share:6.1f} {100 * r.raw_walls_ok:6.1f}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], epilog=__doc__.split("\n\n", 1)[1],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--worlds", nargs="+", default=list(WORLDS), help=f"from {', '.join(WORLDS)}")
    ap.add_argument("--sensors", nargs="+", choices=tuple(ROBOTS), default=list(ROBOTS))
    ap.add_argument("--runs", type=int, default=1, help="runs of each world and sensor")
    ap.add_argument("--speed", type=float, default=2.0, help="simulator speed (x real time) when the machine keeps up")
    ap.add_argument("--time-limit", type=float, default=1800.0, metavar="S", help="simulated seconds per run")
    ap.add_argument("--set", action="append", default=[], metavar="NODE.KEY=VALUE", dest="master_set",
                    help="one of the master's parameters (zenav master --set), e.g. slam_gmapping.maxUrange=30")
    ap.add_argument("--robot-set", action="append", default=[], metavar="NODE.KEY=VALUE",
                    help="one of the robot's parameters (zenav robot --set), e.g. sim.base.gyro=true")
    ap.add_argument("--engine", choices=("kinematic", "mujoco"), default=None,
                    help="simulator engine (default: the robot YAML's, the kinematic one); mujoco: the skid-steered "
                         "P3-AT on rigid-body physics, with DWA and its odometry told where it turns about")
    ap.add_argument("--record", action="store_true",
                    help="also record each run's scan, odometry, tf_static and ground truth into <run dir>/run.mcap "
                         "(zenav record): `zenav slam run run.mcap` maps the same data again offline")
    ap.add_argument("--record-more", default="", metavar="TOPICS",
                    help="with --record, these topics too (comma-separated), e.g. cmd_vel,move_base/local_plan,"
                         "move_base/cmd_trace,local_costmap/costmap: what the planner chose and on which costmap")
    ap.add_argument("--out", default="", help="where each run's logs and map go (default: a new temp dir)")
    a = ap.parse_args(argv)
    # on physics DWA and the robot's odometry are told where the P3-AT turns about (deploy/stack/physics_sets.py)
    # and with the laser, the escape may turn then drive (deploy/stack/sensor_sets.py)
    master_set = (*master_sets(a.engine, amcl=False), *a.master_set)
    robot_args = (*(("--engine", a.engine) if a.engine else ()), *set_options((*robot_sets(a.engine), *a.robot_set)))
    out = Path(a.out or tempfile.mkdtemp(prefix="zenav-explore-bench-"))
    runs: list[ExploreRun] = []
    print(f"logs and maps under {out}", file=sys.stderr)
    record = (*RECORDED, *filter(None, a.record_more.split(","))) if a.record else ()
    todo = [(w, sensor, k) for w in a.worlds for sensor in a.sensors for k in range(a.runs)]
    for w, sensor, k in todo:
        world, start = world_and_start(w)
        name = f"{w}/{sensor}/{k + 1}"
        print(f"{name}: exploring from ({start.x:.1f}, {start.y:.1f}) ...", file=sys.stderr, flush=True)
        t0 = time.monotonic()
        with terminate_as_interrupt(once=True):  # Ctrl-C, SIGTERM: the run is measured and its processes stopped
            r = run_exploration(name, world, start, ROBOTS[sensor], MASTER, out, a.speed, a.time_limit,
                                echo=lambda s: print(s, file=sys.stderr, flush=True),
                                master_set=(*slam_sensor_sets(sensor), *master_set),
                                robot_args=robot_args, record=record)
        runs.append(r)
        print(f"{name}: {r.end}, {100 * r.final_share:.1f} % known in {r.sim_s:.0f} s simulated "
              f"({time.monotonic() - t0:.0f} s wall)" + "".join(
                  f"; contact at ({x:.2f}, {y:.2f}) at {t:.0f} s ({_known(d)})"
                  for (t, x, y), d in zip(r.contacts, r.contact_marks)) + f"; SLAM: {r.slam}",
              file=sys.stderr, flush=True)
        if r.end == INTERRUPTED:  # Ctrl-C: the table of what was measured, then stop
            break
    print(f"{'run':24} {'end':11} {'known%':>6} {'t95 s':>8} {'sim s':>7} {'path m':>7} {'walls%':>6} "
          f"{'free%':>6} {'hits':>4} {'area m2':>7} {'wall s':>7} {'map frame':>12} {'raw k%':>6} {'raw w%':>6}")
    for r in runs:
        print(row(r))
    reached = [r.time_to(0.95) for r in runs if math.isfinite(r.time_to(0.95))]
    print(f"explore_runs={len(runs)} explore_coverage_pct={min(100 * r.final_share for r in runs):.1f} "
          f"explore_time_95_s={sum(reached) / len(reached) if reached else float('inf'):.0f} "
          f"explore_path_m={sum(r.path_m for r in runs) / len(runs):.1f} "
          f"explore_map_agreement_pct={min(100 * r.agreement for r in runs):.1f} "
          f"explore_map_walls_unfitted_pct={min(100 * r.raw_walls_ok for r in runs):.1f} "
          f"explore_collisions={sum(r.collisions for r in runs)} "
          f"explore_ended_by_itself={sum(r.end == 'done' for r in runs)}/{len(runs)}")
    return 130 if runs and runs[-1].end == INTERRUPTED else 0


if __name__ == "__main__":
    raise SystemExit(main())
