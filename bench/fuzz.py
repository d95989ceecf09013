"""Hostile bus input against every node type (see testkit/fuzz_harness.py for what is started and checked).

    python bench/fuzz.py [--per-topic 10000]

Prints, per node and subscribed topic, the payloads sent by label (malformed / invalid / valid) and what
the node counted; then one summary line. Exit status 1 if any payload was miscounted, a callback raised,
a process died or restarted, or a topic stopped flowing.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from testkit.fuzz_harness import run  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--per-topic", type=int, default=10_000, help="hostile payloads per subscribed topic")
    args = ap.parse_args()
    t0 = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="zenav_fuzz_") as tmp:
        rows, problems = run(args.per_topic, Path(tmp), log=lambda m: print(m, flush=True))
    print(f"\n{'grp':3} {'node':22} {'topic':28} {'type':22} {'sent':>6} {'malf':>6} {'inval':>6} "
          f"{'valid':>5} | {'malf':>6} {'inval':>6} {'recv':>6} {'err':>3}  ok")
    for r in rows:
        e, g = r.expected, r.got
        print(f"{r.group:3} {r.node:22.22} {r.topic:28.28} {r.msg_type:22.22} {r.sent:6d} {e['malformed']:6d} "
              f"{e['invalid']:6d} {e['valid']:5d} | {g['malformed']:6d} {g['invalid']:6d} {g['received']:6d} "
              f"{g['errors']:3d}  {'ok' if r.ok else 'FAIL'}")
    for p in problems:
        print("problem:", p)
    bad = [r for r in rows if not r.ok]
    sent = sum(r.sent for r in rows)
    print(f"fuzz_nodes={len({(r.group, r.node) for r in rows})} fuzz_subscriptions={len(rows)} "
          f"fuzz_payloads={sent} fuzz_lost={sum(r.lost for r in rows)} "
          f"fuzz_miscounted={len(bad)} fuzz_callback_errors={sum(r.got['errors'] for r in rows)} "
          f"fuzz_problems={len(problems)} fuzz_wall_s={time.monotonic() - t0:.0f}")
    return 1 if bad or problems else 0


if __name__ == "__main__":
    sys.exit(main())
