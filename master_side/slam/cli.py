"""`zenav slam run LOG --out DIR ...`, `zenav slam eval --relations REL TRAJ`, `zenav slam odom-noise LOG TRAJ`
and `zenav slam laser-noise LOG TRAJ` (hook: main(argv))."""

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
    ap.add_argument("log", help="CARMEN .clf/.log, ROS1 .bag (/scan, /odom) or MCAP (zenav record)")
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


def _matched(prog: str, log: str, trajectory: str, first: float):
    """The log's records at the trajectory's stamps and the trajectory's poses there, the first ``first``
    share of them; or an exit status (2) with the reason on stderr."""
    import numpy as np

    from master_side.slam.logs import read_log

    if not 0.0 < first <= 1.0:
        print(f"{prog}: --first {first}: a share in (0, 1]", file=sys.stderr)
        return 2
    try:
        stamps, ref = evaluate.read_trajectory(trajectory)
        at = {round(r.stamp, 6): r for r in read_log(log)}
    except (LogError, OSError, ValueError) as e:
        print(f"{prog}: {e}", file=sys.stderr)
        return 2
    keep = [i for i, t in enumerate(stamps) if round(float(t), 6) in at]
    if len(keep) < 0.9 * len(stamps):
        print(f"{prog}: only {len(keep)} of the trajectory's {len(stamps)} stamps are scans of "
              f"{log}: a trajectory of another log?", file=sys.stderr)
        return 2
    keep = keep[:max(int(len(keep) * first), 3)]
    return [at[round(float(stamps[i]), 6)] for i in keep], np.asarray(ref[keep])


def _log_and_trajectory(ap: argparse.ArgumentParser, log_help: str) -> None:
    """The arguments odom-noise and laser-noise share (read by ``_matched``)."""
    ap.add_argument("log", help=log_help)
    ap.add_argument("trajectory", help="timestamp x y theta per scan (zenav slam run --out DIR: DIR/trajectory.txt)")
    ap.add_argument("--first", type=float, default=1.0, metavar="SHARE",
                    help="fit on this share of the log from its start (default 1: all of it)")


def _odom_noise(argv: list[str]) -> int:
    import numpy as np

    from master_side.localization.odom_noise import fit

    ap = argparse.ArgumentParser(
        prog="zenav slam odom-noise",
        description="amcl's odom_alpha1..4 measured from a log's odometry against a trajectory of the same log "
                    "(zenav slam run's trajectory.txt): the alphas under which the odometry's errors over "
                    "amcl's update steps are most likely (master_side/localization/odom_noise.py)")
    _log_and_trajectory(ap, "CARMEN .clf/.log, ROS1 .bag (/scan, /odom) or MCAP: the odometry at each scan")
    ap.add_argument("--model", choices=("diff", "diff-corrected"), default="diff",
                    help="amcl's odom_model_type the alphas are for (default diff, ROS's default)")
    ap.add_argument("--update-min-d", type=positive, default=0.2, help="amcl's update_min_d (m, default 0.2)")
    ap.add_argument("--update-min-a", type=positive, default=0.5236, help="amcl's update_min_a (rad, default π/6)")
    a = ap.parse_args(argv)
    got = _matched(ap.prog, a.log, a.trajectory, a.first)
    if isinstance(got, int):
        return got
    recs, ref = got
    try:
        r = fit(np.array([rec.odom.as_array() for rec in recs]), ref, a.model, a.update_min_d, a.update_min_a)
    except ValueError as e:
        print(f"zenav slam odom-noise: {e}", file=sys.stderr)
        return 2
    print(f"# {r.pieces} steps of {a.update_min_d:g} m / {a.update_min_a:g} rad; heading error "
          f"{r.heading_err_rms_deg:.2f} deg rms, distance error {r.trans_err_rms_m:.3f} m rms per step")
    print(r.yaml())
    return 0


def _laser_noise(argv: list[str]) -> int:
    from common.geometry import Pose2D
    from master_side.localization.laser_noise import end_point_distances, fit
    from master_side.localization.likelihood_field import LikelihoodField
    from master_side.mapping.map_io import MapFormatError, load_map

    ap = argparse.ArgumentParser(
        prog="zenav slam laser-noise",
        description="amcl's laser_sigma_hit measured from a log's scans, seen from a trajectory of the same log, "
                    "against a map of the place (zenav slam run's trajectory.txt and map.yaml): the deviation "
                    "of the beams' end points from the map's obstacles (master_side/localization/laser_noise.py)")
    _log_and_trajectory(ap, "CARMEN .clf/.log, ROS1 .bag (/scan, /odom) or MCAP (zenav record)")
    ap.add_argument("--map", help="map_server YAML (default: map.yaml beside the trajectory)")
    ap.add_argument("--laser-max-range", type=positive, default=None,
                    help="amcl's laser_max_range (m; default: the scans' range_max): longer beams are left out")
    ap.add_argument("--likelihood-max-dist", type=positive, default=2.0,
                    help="amcl's laser_likelihood_max_dist (m, default 2.0)")
    a = ap.parse_args(argv)
    map_path = Path(a.map) if a.map else Path(a.trajectory).with_name("map.yaml")
    try:
        grid = load_map(map_path)
    except MapFormatError as e:  # it names the file
        print(f"{ap.prog}: cannot read the map: {e}", file=sys.stderr)
        return 2
    got = _matched(ap.prog, a.log, a.trajectory, a.first)
    if isinstance(got, int):
        return got
    recs, ref = got
    field = LikelihoodField(grid, a.likelihood_max_dist)
    range_max = a.laser_max_range or recs[0].scan.range_max
    d = end_point_distances(field, ref, ((r.scan.ranges, r.scan.angles()) for r in recs), Pose2D(),
                            recs[0].scan.range_min, range_max)
    try:
        r = fit(d, a.likelihood_max_dist)
    except ValueError as e:
        print(f"{ap.prog}: {e}", file=sys.stderr)
        return 2
    print(f"# {r.beams} beam end points of {len(recs)} scans; {r.hit_share:.1%} explained by the hit part "
          f"(the rest: what the map lacks)")
    print(r.yaml())
    return 0


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help"):
        print("usage: zenav slam {run,eval,odom-noise,laser-noise} ...")
        return 0 if argv else 2
    cmd, rest = argv[0], argv[1:]
    if cmd == "run":
        return _run(rest)
    if cmd == "eval":
        return evaluate.main(rest)
    if cmd == "odom-noise":
        return _odom_noise(rest)
    if cmd == "laser-noise":
        return _laser_noise(rest)
    print(f"unknown slam command {cmd!r} (run, eval, odom-noise, laser-noise)", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
