"""``zenav slam run|eval``: offline SLAM on a log and its evaluation (master_side.slam.cli)."""

from __future__ import annotations

import argparse

DESCRIPTION = """\
run LOG --out DIR [--config gmapping.yaml] [--particles N] [--max-scans N] [--set KEY=VALUE]
    gmapping-style SLAM over a CARMEN log (FLASER/ODOM), a ROS1 bag (/scan, /odom) or an MCAP file of
    `zenav record` (scan, odom, tf_static: the laser's place on the base); writes DIR/map.pgm,
    DIR/map.yaml and DIR/trajectory.txt (one `timestamp x y theta` line per scan).
eval --relations REL DIR/trajectory.txt
    Kümmerle et al. relation metric; the last line is machine-readable
    (trans_mean_m=... trans_std_m=... rot_mean_deg=... rot_std_deg=... relations=...).
odom-noise LOG DIR/trajectory.txt [--model diff|diff-corrected] [--first SHARE]
    amcl's odom_alpha1..4 measured: the odometry's errors against the trajectory over amcl's update
    steps; prints the lines for amcl's parameters (instead of guessing them).
laser-noise LOG DIR/trajectory.txt [--map DIR/map.yaml] [--laser-max-range M] [--first SHARE]
    amcl's laser_sigma_hit measured: the deviation of the scans' end points, seen from the trajectory,
    from the map's obstacles; prints the line for amcl's parameters.

example:
  zenav slam run ../shared/datasets/slam/aces.recon.clf \
      --config master_side/config/gmapping_datasets.yaml --out out/aces
  zenav slam eval --relations ../shared/datasets/slam/aces.relations out/aces/trajectory.txt
  zenav slam odom-noise ../shared/datasets/slam/aces.recon.clf out/aces/trajectory.txt
  zenav slam laser-noise ../shared/datasets/slam/aces.recon.clf out/aces/trajectory.txt
"""


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser("slam", help="offline SLAM on a log (run), its evaluation (eval), odometry and "
                                           "laser noise for amcl (odom-noise, laser-noise)",
                              description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("action", choices=("run", "eval", "odom-noise", "laser-noise"),
                   help="run SLAM on a log, evaluate a trajectory, or measure amcl's odometry or laser noise")
    p.add_argument("rest", nargs=argparse.REMAINDER, help="arguments of the action (see above)")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    from deploy.logs.mcap_io import read_records
    from master_side.slam.cli import main
    from master_side.slam.logs import register_reader, scan_records

    # MCAP is parsed here, in deploy (as `zenav play` parses it); SLAM reads its messages as scan records
    register_reader(".mcap", lambda path: scan_records(((r.topic, r.msg) for r in read_records(path)), str(path)))

    return main([args.action, *args.rest])
