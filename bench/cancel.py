"""Cancel latency: move_base/cancel published -> the first zero cmd_vel, over a whole stack.

    python bench/cancel.py [--cancels 30] [--hog 0] [--planner dwa|trajectory]

`zenav robot` (simulated P3-AT, room world) and `zenav master` (known map) run as separate process groups
on a private loopback Zenoh bus (testkit.nav_stack, as the navigation tests); this process is a third
peer. Each round sends a goal across the room, lets the robot drive for a random 0.3-1.5 s of
CONTROLLING, publishes an empty `move_base/cancel` and takes the wall time until the first zero Twist
arrives here on `cmd_vel` (two bus hops, move_base's reaction and every scheduling delay between), with
the navigation tests' own check (testkit.nav_goals.cancel_and_measure): PREEMPTED, said who cancelled, and
no non-zero command after that zero. The issue-6 target is 100 ms.

``--hog N`` runs N busy processes beside it. The tests check the same path on a loaded machine with a
wider bound (tests/nav_e2e/nav_e2e_checks.py); the figure belongs here.
"""

from __future__ import annotations

import argparse
import multiprocessing
import random
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import numpy as np  # noqa: E402

from testkit.nav_goals import cancel_and_measure, send_goal_async, status_of  # noqa: E402
from testkit.nav_stack import NavStack, world_goals  # noqa: E402

TARGET_S = 0.1


def _hog() -> None:
    while True:
        pass


def one_round(stack: NavStack, goal: tuple[float, float, float], rng: random.Random) -> float:
    gid = send_goal_async(stack, goal)
    status_of(stack, gid, lambda m: m.state == "CONTROLLING", 60.0, "CONTROLLING")
    time.sleep(rng.uniform(0.3, 1.5))  # a random moment of the drive (the thing measured is not a wait)
    return cancel_and_measure(stack)  # also fails on a non-zero command after the zero


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cancels", type=int, default=30, help="rounds (default 30)")
    ap.add_argument("--hog", type=int, default=0, help="busy processes beside the run (default 0)")
    ap.add_argument("--planner", choices=("dwa", "trajectory"), default="dwa")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    rng = random.Random(args.seed)
    goals = list(world_goals("room").values())
    hogs = [multiprocessing.Process(target=_hog, daemon=True) for _ in range(args.hog)]
    delays: list[float] = []
    with tempfile.TemporaryDirectory(prefix="zenav-bench-cancel-") as tmp:
        print(f"starting the stack (room, {args.planner}) ...", flush=True)
        stack = NavStack(Path(tmp), "room", args.planner)
        try:
            for h in hogs:
                h.start()
            for i in range(args.cancels):
                delays.append(one_round(stack, goals[i % len(goals)], rng))
                print(f"  cancel {i + 1:3d}/{args.cancels}: first zero cmd_vel after {delays[-1] * 1000:6.1f} ms",
                      flush=True)
        finally:
            for h in hogs:
                h.terminate()
            stack.close()
    ms = np.array(delays) * 1000
    print(f"\n| cancels | hog procs | p50 ms | p90 ms | p99 ms | max ms | over {TARGET_S * 1000:.0f} ms |")
    print("|---|---|---|---|---|---|---|")
    p50, p90, p99 = np.percentile(ms, [50, 90, 99])
    over = int((ms > TARGET_S * 1000).sum())
    print(f"| {len(ms)} | {args.hog} | {p50:.1f} | {p90:.1f} | {p99:.1f} | {ms.max():.1f} | {over} |")
    print(f"cancel_n={len(ms)} cancel_p50_ms={p50:.1f} cancel_p99_ms={p99:.1f} cancel_max_ms={ms.max():.1f} "
          f"cancel_over_100ms={over} hog_procs={args.hog} planner={args.planner}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
