"""BARN: the simulated Jackal crosses the benchmark's training worlds (../shared/datasets/barn).

Two modes:
  --mode fast  simulator, costmaps and move_base stepped in one process on the simulated clock, no bus
               (deploy/barn/inproc.py): faster than real time, for iterating on planners and parameters.
  --mode bus   the real thing: `zenav robot` (jackal_sim.yaml) and `zenav master` as separate processes
               over a private loopback Zenoh network, the goal sent as the challenge does (0, 10) in odom,
               the verdict from the simulator's ground_truth and collision topics (deploy/barn/bus.py).

Each run is judged by BARN's rule (deploy/barn/rules.py): success within 1 m of the goal without a collision
within 100 s of simulated time from the start of motion; score = success x OT / clip(AT, 2 OT, 8 OT).

  python bench/barn.py --mode fast --worlds 50                  # the challenge's own files (jackal_barn.yaml)
  python bench/barn.py --mode bus --worlds 50 --master master_side/config/jackal_barn_zenav.yaml

The default selection of N worlds is every (250 / N)-th training world, so it spans the whole set.
Prints one row per world, then a table and the summary line
barn_success=… barn_collision=… barn_timeout=… barn_time_mean_s=… barn_score=… worlds=…
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from deploy.barn import rules as barn  # noqa: E402
from deploy.barn.inproc import MASTER_CONFIG, ROBOT_CONFIG  # noqa: E402


def select_worlds(n: int, listed: str) -> list[int]:
    if listed:
        return [int(x) for x in listed.split(",") if x.strip()]
    all_worlds = barn.training_worlds()
    step = max(1, len(all_worlds) // n)
    return all_worlds[::step][:n]


def _fast(args: tuple) -> dict:
    world, workdir, master, robot, plan_hz, engine, friction = args
    from deploy.barn.inproc import BarnStack
    from robot_side.worlds.barn import GOAL

    path = barn.write_world(world, workdir)
    stack = BarnStack(path, robot_config=robot, master_config=master, plan_hz=plan_hz, seed=world,
                           engine=engine, friction=friction)
    o = stack.run(world, GOAL)
    return {"run": o.run, "cycle_ms": o.cycle_ms, "plan_ms": o.plan_ms, "wall_s": o.wall_s,
            "note": o.final_state if not o.run.success else ""}


def _bus(args: tuple) -> dict:
    world, workdir, master, robot, speed, engine, friction = args
    from deploy.barn.bus import run_world_bus

    return run_world_bus(world, workdir, master_config=master, robot_config=robot, speed=speed, engine=engine,
                         friction=friction)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    ap.add_argument("--mode", choices=("fast", "bus"), default="fast")
    ap.add_argument("--worlds", type=int, default=50, help="how many training worlds (spread over all 250)")
    ap.add_argument("--world-list", default="", help="explicit comma-separated world indices instead")
    ap.add_argument("--master", default=str(MASTER_CONFIG), help="master YAML (default: the challenge's files)")
    ap.add_argument("--robot", default=str(ROBOT_CONFIG), help="robot YAML (default: the simulated Jackal)")
    ap.add_argument("--jobs", type=int, default=2, help="worlds run at once (fast mode)")
    ap.add_argument("--plan-hz", type=float, default=5.0,
                    help="fast mode: simulated rate of the global planner thread (at most planner_frequency)")
    ap.add_argument("--speed", type=float, default=1.0, help="bus mode: simulated time x real time")
    ap.add_argument("--engine", choices=("kinematic", "mujoco"), default=None,
                    help="simulator engine (default: the robot YAML's, the kinematic one)")
    ap.add_argument("--friction", type=float, default=None,
                    help="mujoco: wheel-floor friction coefficient (default: PhysicsParams, 0.9)")
    ap.add_argument("--workdir", default="", help="where world files and logs go (default: a temp folder)")
    a = ap.parse_args(argv)
    worlds = select_worlds(a.worlds, a.world_list)
    work = Path(a.workdir or tempfile.mkdtemp(prefix="zenav-barn-"))
    work.mkdir(parents=True, exist_ok=True)
    engine = a.engine or "the robot YAML's"
    print(f"# BARN {a.mode} mode: {len(worlds)} worlds, engine {engine}"
          f"{f' (friction {a.friction:g})' if a.friction is not None else ''}, master {a.master}, work dir {work}",
          flush=True)
    t0 = time.monotonic()
    if a.mode == "fast":
        jobs = [(w, str(work), a.master, a.robot, a.plan_hz, a.engine, a.friction) for w in worlds]
        with ProcessPoolExecutor(max_workers=max(1, a.jobs)) as ex:
            results = list(_progress(ex.map(_fast, jobs), len(jobs), t0))
    else:
        from deploy.stack.process_group import terminate_as_interrupt

        jobs = [(w, str(work), a.master, a.robot, a.speed, a.engine, a.friction) for w in worlds]
        with terminate_as_interrupt():  # a killed bench stops each world's robot and master agents too
            results = list(_progress(map(_bus, jobs), len(jobs), t0))
    runs = [r["run"] for r in results]
    s = barn.summarize(runs)
    print("\n| runs | success | collision | timeout | mean time of successes (s) | score |")
    print("|---|---|---|---|---|---|")
    print(f"| {s.runs} | {s.success_rate:.3f} | {s.collision_rate:.3f} | {s.timeout_rate:.3f} | "
          f"{s.mean_time_success_s:.1f} | {s.mean_score:.4f} |")
    extra = ""
    cycles = [r["cycle_ms"] for r in results if len(r.get("cycle_ms", ())) > 0]
    if cycles:
        c = np.concatenate(cycles)
        extra = f" control_cycle_p50_ms={np.percentile(c, 50):.2f} control_cycle_p95_ms={np.percentile(c, 95):.2f}"
    print(f"barn_success={s.success_rate:.3f} barn_collision={s.collision_rate:.3f} "
          f"barn_timeout={s.timeout_rate:.3f} barn_time_mean_s={s.mean_time_success_s:.2f} "
          f"barn_score={s.mean_score:.4f} worlds={s.runs}{extra} wall_s={time.monotonic() - t0:.0f}")
    return 0


def _progress(results, n: int, t0: float):
    for i, r in enumerate(results, 1):
        run = r["run"]
        note = f"  {r['note']}" if r.get("note") else ""
        t = f"{run.time_s:5.1f} s" if not math.isnan(run.time_s) else "  -  "
        print(f"[{i:3d}/{n}] world {run.world:3d}: {run.status:9s} {t}  score {run.score:.3f}  "
              f"({time.monotonic() - t0:.0f} s){note}", flush=True)
        yield r


if __name__ == "__main__":
    raise SystemExit(main())
