"""`zenav slam run LOG --out DIR ...`, `zenav slam eval --relations REL TRAJ` and `zenav slam odom-noise LOG TRAJ`
(hook: main(argv))."""

from __future__ import annotations

import argparse
import importlib
import sys
from pathlib import Path
from typing import Any

from common.argtypes import positive, positive_int
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


def _odom_noise(argv: list[str]) -> int:
    import numpy as np

    from master_side.localization.odom_noise import fit
    from master_side.slam.logs import read_log

    ap = argparse.ArgumentParser(
        prog="zenav slam odom-noise",
        description="amcl's odom_alpha1..4 measured from a log's odometry against a trajectory of the same log "
                    "(zenav slam run's trajectory.txt): the alphas under which the odometry's errors over "
                    "amcl's update steps are most likely (master_side/localization/odom_noise.py)")
    ap.add_argument("log", help="CARMEN .clf/.log or ROS1 .bag (/scan, /odom): the odometry at each scan")
    ap.add_argument("trajectory", help="timestamp x y theta per scan (zenav slam run --out DIR: DIR/trajectory.txt)")
    ap.add_argument("--model", choices=("diff", "diff-corrected"), default="diff",
                    help="amcl's odom_model_type the alphas are for (default diff, ROS's default)")
    ap.add_argument("--update-min-d", type=positive, default=0.2, help="amcl's update_min_d (m, default 0.2)")
    ap.add_argument("--update-min-a", type=positive, default=0.5236, help="amcl's update_min_a (rad, default π/6)")
    ap.add_argument("--first", type=float, default=1.0, metavar="SHARE",
                    help="fit on this share of the log from its start (default 1: all of it)")
    a = ap.parse_args(argv)
    if not 0.0 < a.first <= 1.0:
        print(f"zenav slam odom-noise: --first {a.first}: a share in (0, 1]", file=sys.stderr)
        return 2
    try:
        stamps, ref = evaluate.read_trajectory(a.trajectory)
        odom_at = {round(r.stamp, 6): r.odom.as_array() for r in read_log(a.log)}
    except (LogError, OSError, ValueError) as e:
        print(f"zenav slam odom-noise: {e}", file=sys.stderr)
        return 2
    keep = [i for i, t in enumerate(stamps) if round(float(t), 6) in odom_at]
    if len(keep) < 0.9 * len(stamps):
        print(f"zenav slam odom-noise: only {len(keep)} of the trajectory's {len(stamps)} stamps are scans of "
              f"{a.log}: a trajectory of another log?", file=sys.stderr)
        return 2
    keep = keep[:max(int(len(keep) * a.first), 3)]
    odom = np.array([odom_at[round(float(stamps[i]), 6)] for i in keep])
    try:
        r = fit(odom, ref[keep], a.model, a.update_min_d, a.update_min_a)
    except ValueError as e:
        print(f"zenav slam odom-noise: {e}", file=sys.stderr)
        return 2
    print(f"# {r.pieces} steps of {a.update_min_d:g} m / {a.update_min_a:g} rad; heading error "
          f"{r.heading_err_rms_deg:.2f} deg rms, distance error {r.trans_err_rms_m:.3f} m rms per step")
    print(r.yaml())
    return 0


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help"):
        print("usage: zenav slam {run,eval,odom-noise} ...")
        return 0 if argv else 2
    cmd, rest = argv[0], argv[1:]
    if cmd == "run":
        return _run(rest)
    if cmd == "eval":
        return evaluate.main(rest)
    if cmd == "odom-noise":
        return _odom_noise(rest)
    print(f"unknown slam command {cmd!r} (run, eval, odom-noise)", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
