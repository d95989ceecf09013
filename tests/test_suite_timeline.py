"""The suite's timeline (tests/conftest.py, ZENAV_TEST_TIMELINE) and its summary (bench/suite_timeline.py):
in a real pytest run on an xdist worker, each test is written once, by the worker (not by the controller
too), and the summary adds the lines up."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def test_a_worker_logs_each_test_once_and_the_summary_adds_them_up(tmp_path):
    timeline = tmp_path / "tl.jsonl"
    env = {**os.environ, "ZENAV_TEST_TIMELINE": str(timeline)}
    run = subprocess.run([sys.executable, "-m", "pytest", "-q", "-n", "1", "-p", "no:cacheprovider",
                          "tests/test_codec.py::test_registry_has_the_issue_message_types",
                          "tests/test_codec.py::test_every_message_type_round_trips[Twist]"],
                         cwd=REPO, env=env, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-2000:]
    passed = int(run.stdout.split(" passed")[0].split()[-1])
    rows = [json.loads(line) for line in timeline.read_text().splitlines()]
    assert len(rows) == passed and len({r["test"] for r in rows}) == passed  # once each, not by the controller
    assert {r["worker"] for r in rows} == {"gw0"}
    assert all(r["end"] >= r["start"] and r["cpu_s"] >= 0 for r in rows)

    out = subprocess.run([sys.executable, str(REPO / "bench" / "suite_timeline.py"), str(timeline)],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    summary = dict(kv.split("=") for kv in out.stdout.strip().splitlines()[-1].split())
    wall = max(r["end"] for r in rows) - min(r["start"] for r in rows)
    assert abs(float(summary["suite_wall_s"]) - wall) <= 0.5
    assert abs(float(summary["suite_cpu_s"]) - sum(r["cpu_s"] for r in rows)) <= 0.5
    assert re.search(rf"^test_codec\.py +{passed} ", out.stdout, re.M), out.stdout
