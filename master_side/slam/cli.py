"""`zenav slam run LOG --out DIR ...` and `zenav slam eval --relations REL TRAJ` (hook: main(argv))."""

from __future__ import annotations

import argparse
import importlib
import sys
from pathlib import Path
from typing import Any

from common.argtypes import positive_int
from common.config import ConfigError
from master_side.slam import evaluate
from master_side.slam.logs import LogError
from master_side.slam.params import load_gmapping


def _run(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(prog="zenav slam run", description="gmapping-style SLAM over a log")
    ap.add_argument("log", help="CARMEN .clf/.log or ROS1 .bag (/scan, /odom)")
    ap.add_argument("--out", required=True, help="output folder (map.pgm, map.yaml, trajectory.txt)")
    ap.add_argument("--method", choices=("gmapping", "hector"), default="gmapping",
                    help="gmapping (particle filter with odometry) or hector (scan matching only: the log's "
                         "odometry is ignored)")
    ap.add_argument("--config", help="gmapping YAML (slam_gmapping parameter names) or, with --method hector, "
                                     "hector_mapping YAML")
    ap.add_argument("--section", default="", help="YAML key holding the parameters")
    ap.add_argument("--particles", type=positive_int, help="number of particles (overrides the config)")
    ap.add_argument("--max-scans", type=positive_int, help="stop after this many scans")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="override one parameter, e.g. --set maxUrange=30")
    a = ap.parse_args(argv)
    overrides: dict = {}
    for kv in a.set:
        k, _, v = kv.partition("=")
        overrides[k] = float(v) if any(c in v for c in ".e") else int(v)
    # the two methods' offline runners share run(log, params, max_scans) and write_outputs(result, out)
    runner: Any = importlib.import_module("master_side.hector.offline" if a.method == "hector"
                                          else "master_side.slam.offline")
    load: Any = load_gmapping
    if a.method == "hector":
        from master_side.hector.params import load_hector

        load = load_hector
    elif a.particles is not None:
        overrides["particles"] = a.particles
    try:
        params = load(a.config, a.section, **overrides)
    except ConfigError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    if not Path(a.log).is_file():
        print(f"zenav slam run: {a.log}: no such file", file=sys.stderr)
        return 2
    try:
        res = runner.run(a.log, params, a.max_scans)
    except (LogError, OSError, ValueError) as e:
        print(f"zenav slam run: {e}", file=sys.stderr)
        return 2
    try:
        runner.write_outputs(res, a.out)
    except OSError as e:
        print(f"zenav slam run: cannot write {a.out}: {e.strerror or e}", file=sys.stderr)
        return 2
    print(f"wrote {a.out}/map.pgm, map.yaml, trajectory.txt ({res.scans} poses)")
    return 0


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help"):
        print("usage: zenav slam {run,eval} ...")
        return 0 if argv else 2
    cmd, rest = argv[0], argv[1:]
    if cmd == "run":
        return _run(rest)
    if cmd == "eval":
        return evaluate.main(rest)
    print(f"unknown slam command {cmd!r} (run, eval)", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
