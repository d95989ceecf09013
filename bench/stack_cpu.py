"""CPU of the simulated robot and the master, per node: standing still, then driving goals.

    python bench/stack_cpu.py [--world room] [--planner dwa] [--seconds 20] [--speed 1]

`zenav robot` (simulated P3-AT, its Kinect -> depth_to_scan -> scan, collision monitor) and `zenav master`
(known map: fake_localization, map_server, both costmaps, move_base) start as separate process groups on a
private loopback bus, as the end-to-end tests start them (testkit/nav_stack.py). Each process's CPU time
(user + system, /proc/<pid>/stat) is read before and after ``--seconds`` of standing still, then of driving
between two of the world's goals. The table gives each node's share of one core; the figure a robot PC
must afford, and what one running stack costs the test suite every second it is up. Start-up CPU (imports,
sessions, kernels loaded from numba's cache) is the sum over the processes when the stack is up.

Ends with ``stack_start_cpu_s=… stack_idle_cpu_pct=… stack_drive_cpu_pct=… robot_drive_cpu_pct=…
master_drive_cpu_pct=…`` (percent of one core; the two sides split at the agents).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import threading
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from testkit.nav_stack import NavStack, world_goals  # noqa: E402

TICK = os.sysconf("SC_CLK_TCK")


def cpu_s(pid: int) -> float:
    """User + system CPU seconds of one process (0 once it is gone)."""
    try:
        f = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return 0.0
    return (int(f[11]) + int(f[12])) / TICK


def measure(pids: dict[int, tuple[str, str]], seconds: float, work=None) -> dict[int, float]:
    """Share of one core per pid over ``seconds`` (``work`` runs meanwhile, on a thread)."""
    before = {p: cpu_s(p) for p in pids}
    t0 = time.monotonic()
    stop = threading.Event()
    th = threading.Thread(target=work, args=(stop,), daemon=True) if work else None
    if th:
        th.start()
    time.sleep(seconds)
    span = time.monotonic() - t0
    stop.set()
    return {p: (cpu_s(p) - before[p]) / span for p in pids}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--world", default="room")
    ap.add_argument("--planner", default="dwa", choices=("dwa", "trajectory"))
    ap.add_argument("--seconds", type=float, default=20.0, help="length of each phase (default 20)")
    ap.add_argument("--speed", type=float, default=1.0,
                    help="simulator speed (x real time; the end-to-end tests run at 2; default 1)")
    args = ap.parse_args()
    goals = list(world_goals(args.world).values())[:2]
    with tempfile.TemporaryDirectory(prefix="stack_cpu") as tmp:
        print(f"starting the {args.world} stack ({args.planner}, {args.speed:g}x) ...", file=sys.stderr, flush=True)
        stack = NavStack(Path(tmp), args.world, args.planner, args.speed)
        try:
            pids = stack.processes()
            start = sum(cpu_s(p) for p in pids)
            print(f"standing still {args.seconds:g} s ...", file=sys.stderr, flush=True)
            idle = measure(pids, args.seconds)

            def drive(stop: threading.Event) -> None:
                i = 0
                while not stop.is_set():
                    try:
                        stack.goal(*goals[i % len(goals)], timeout=args.seconds + 30)
                    except Exception:  # noqa: BLE001 - the stack closing under the last goal
                        return
                    i += 1
            print(f"driving between {goals} for {args.seconds:g} s ...", file=sys.stderr, flush=True)
            busy = measure(pids, args.seconds, drive)
        finally:
            stack.close()
    print(f"{'side':7} {'node':26} {'idle %':>7} {'driving %':>9}")
    for p in sorted(pids, key=lambda p: (pids[p][0], -busy[p])):
        print(f"{pids[p][0]:7} {pids[p][1]:26} {100 * idle[p]:7.1f} {100 * busy[p]:9.1f}")
    side = {s: 100 * sum(busy[p] for p in pids if pids[p][0] == s) for s in ("robot", "master")}
    print(f"{'':7} {'total':26} {100 * sum(idle.values()):7.1f} {100 * sum(busy.values()):9.1f}")
    print(f"stack_start_cpu_s={start:.1f} stack_idle_cpu_pct={100 * sum(idle.values()):.1f} "
          f"stack_drive_cpu_pct={100 * sum(busy.values()):.1f} robot_drive_cpu_pct={side['robot']:.1f} "
          f"master_drive_cpu_pct={side['master']:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
