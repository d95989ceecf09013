"""Where a parallel test run's time goes, from the timeline tests/conftest.py writes.

    ZENAV_TEST_TIMELINE=/tmp/tl.jsonl python3 -m pytest -q
    python bench/suite_timeline.py /tmp/tl.jsonl [--top 25]

Prints, per test folder, the wall and CPU seconds its tests took (CPU: the worker's and its reaped
children's, so processes a test starts and stops count); how many workers were busy over the run; the
tail (from when the first worker ran out of tests to the end); and the tests with the most wall time
beyond its CPU seconds (waiting: for a core, with more workers than cores, or for something slower
than a computation — a timeout, a deadline, a real-time simulation).
"""

from __future__ import annotations

import argparse
import json
from collections import defaultdict

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("timeline", help="the file ZENAV_TEST_TIMELINE named")
    ap.add_argument("--top", type=int, default=25, help="how many tests to list (default 25)")
    a = ap.parse_args()
    with open(a.timeline) as f:
        rows = [json.loads(line) for line in f if line.strip()]
    if not rows:
        raise SystemExit(f"{a.timeline}: no tests recorded")
    t0 = min(r["start"] for r in rows)
    t1 = max(r["end"] for r in rows)
    wall = t1 - t0
    cpu = sum(r["cpu_s"] for r in rows)

    folders: dict[str, list[float]] = defaultdict(lambda: [0.0, 0.0, 0])
    for r in rows:
        parts = r["test"].split("/")
        f = folders[parts[1] if len(parts) > 2 else parts[-1].split("::")[0]]
        f[0] += r["end"] - r["start"]
        f[1] += r["cpu_s"]
        f[2] += 1
    print(f"{'folder':<18} {'tests':>5} {'wall s':>8} {'cpu s':>8} {'cpu/wall':>8}")
    for name, (w, c, n) in sorted(folders.items(), key=lambda kv: -kv[1][0]):
        print(f"{name:<18} {n:>5} {w:8.1f} {c:8.1f} {c / max(w, 1e-9):8.2f}")

    workers = sorted({r["worker"] for r in rows})
    last_end = {w: max(r["end"] for r in rows if r["worker"] == w) for w in workers}
    grid = np.arange(t0, t1, 1.0)
    busy = np.zeros(len(grid), int)
    for r in rows:
        busy[(grid >= r["start"]) & (grid < r["end"])] += 1
    tail = t1 - min(last_end.values())
    print(f"\n{len(rows)} tests on {len(workers)} worker(s), {wall:.0f} s wall, {cpu:.0f} s CPU "
          f"({cpu / wall:.2f} cores on average)")
    for k in range(len(workers) + 1):
        print(f"  {k} worker(s) busy: {np.mean(busy == k) * 100:5.1f} % of the run")
    print("  workers ran out of tests at: "
          + ", ".join(f"{w} {last_end[w] - t0:.0f} s" for w in workers) + f"; tail {tail:.0f} s")

    print(f"\n{'test (most wall time not spent on a core)':<100} {'wall s':>7} {'cpu s':>7}")
    waits = sorted(rows, key=lambda r: -((r["end"] - r["start"]) - r["cpu_s"]))
    for r in waits[:a.top]:
        print(f"{r['test'][:100]:<100} {r['end'] - r['start']:7.1f} {r['cpu_s']:7.1f}")
    idle = sum(max(0.0, (r["end"] - r["start"]) - r["cpu_s"]) for r in rows)
    print(f"suite_wall_s={wall:.0f} suite_cpu_s={cpu:.0f} suite_cores_used={cpu / wall:.2f} "
          f"suite_tail_s={tail:.0f} suite_test_wait_s={idle:.0f}")


if __name__ == "__main__":
    main()
