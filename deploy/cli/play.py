"""``zenav play LOG``: replay a ROS1 bag, a CARMEN log or an MCAP file onto the bus (deploy.logs)."""

from __future__ import annotations

import argparse
import sys
import time

from common.argtypes import finite, nonneg, positive

DESCRIPTION = """\
Publishes a recorded log on the bus, like `rosbag play`, with a `clock` topic so that every node
started with use_sim_time (ZENAV_USE_SIM_TIME=1, `use_sim_time: true` in an agent config) runs on the
log's time:
  .bag        ROS1 bag: LaserScan, Odometry, TF (/tf, /tf_static), depth Image (32FC1 m, 16UC1 mm)
              and CameraInfo; topics keep their names without the leading '/'. A bag without /tf gets
              odom -> base_link from its Odometry messages.
  .clf .log   CARMEN: FLASER / ROBOTLASER1 -> scan (frame laser) + tf odom -> base_link from the
              line's odometry (what `zenav slam run` uses); ODOM -> odom.
  .mcap       MCAP written by `zenav record`.
A log without a static base_link -> laser transform gets one on tf_static (latched): identity, or
--laser-pose X Y YAW (which also replaces the log's own).
The clock ticks every 10 ms of log time and once before each message, and runs 1 s past the last
message. Progress (log time / total, rate achieved, messages sent) goes to stderr.

online SLAM on a log (two terminals; the master's slam_gmapping follows the log's clock):
  zenav master --config master_side/config/slam_datasets.yaml
  zenav play ../shared/datasets/slam/ros1_bags/aces.orig.bag --rate 2 --wait-for scan \\
      --trajectory out/aces_online.txt
  zenav slam eval --relations ../shared/datasets/slam/aces.relations out/aces_online.txt
--trajectory asks the SLAM node (service <slam-node>/trajectory) for the pose of every scan once the
log has been played, computed as `zenav slam run` does, and writes it in trajectory.txt format.

other examples:
  zenav play run.bag --start 30 --duration 60 --rate 0.5      a minute from 30 s, half speed
  zenav play run.bag --remap scan:=base_scan --topics scan,tf,tf_static --loop
"""


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser("play", help="replay a ROS1 bag / CARMEN log / MCAP file onto the bus (with clock)",
                              description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("log", help="the log: .bag (ROS1), .clf / .log (CARMEN) or .mcap")
    p.add_argument("--rate", type=positive, default=1.0, help="log seconds per wall second (default 1)")
    p.add_argument("--start", type=nonneg, default=0.0, metavar="S", help="skip the first S log seconds")
    p.add_argument("--duration", type=positive, metavar="D", help="play only D log seconds")
    p.add_argument("--loop", action="store_true", help="play again at the end (stamps shifted, the clock "
                   "never goes backwards); Ctrl-C stops")
    p.add_argument("--remap", action="append", default=[], metavar="OLD:=NEW",
                   help="publish the log's topic OLD as NEW (repeatable)")
    p.add_argument("--topics", metavar="A,B", help="play only these log topics (names before --remap)")
    p.add_argument("--no-clock", action="store_true", help="do not publish the clock topic")
    p.add_argument("--laser-pose", type=finite, nargs=3, metavar=("X", "Y", "YAW"),
                   help="static base_link -> laser transform (m, m, rad; default: the log's, else identity)")
    p.add_argument("--wait-for", metavar="TOPIC[,TOPIC]",
                   help="wait (up to --wait-timeout) until these bus topics have a subscriber before playing")
    p.add_argument("--wait-timeout", type=positive, default=30.0, metavar="S", help="default 30 s")
    p.add_argument("--delay", type=nonneg, default=0.5, metavar="S",
                   help="wall seconds between connecting and the first message (discovery; default 0.5)")
    p.add_argument("--trajectory", metavar="OUT.txt", help="after the log, fetch the SLAM node's trajectory "
                   "and write it (stamp x y theta per scan; `zenav slam eval` reads it)")
    p.add_argument("--slam-node", default="slam_gmapping", metavar="NAME",
                   help="the SLAM node whose trajectory --trajectory fetches (default slam_gmapping)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress line")
    p.set_defaults(func=run)
    return p


def _names(text: str | None) -> list[str]:
    return [t.strip().strip("/") for t in (text or "").split(",") if t.strip().strip("/")]


def _remaps(items: list[str]) -> dict[str, str]:
    out = {}
    for item in items:
        old, sep, new = item.partition(":=")
        old, new = old.strip().strip("/"), new.strip().strip("/")
        if not sep or not old or not new:
            raise ValueError(f"--remap {item!r}: expected OLD:=NEW, e.g. scan:=base_scan")
        out[old] = new
    return out


def run(args) -> int:
    from deploy.logs.player import Player, PlayOptions
    from deploy.logs.readers import LogError, open_log

    remap = _remaps(args.remap)  # ValueError -> one line, exit 2 (deploy.cli)
    pose = tuple(args.laser_pose) if args.laser_pose else None
    try:
        records, info = open_log(args.log, laser_pose=pose)
    except (LogError, ImportError) as e:
        print(f"zenav play: {e}", file=sys.stderr)
        return 2
    if info.duration is not None and args.start > info.duration:
        print(f"zenav play: --start {args.start:g} is past the end of {args.log} ({info.duration:.1f} s)",
              file=sys.stderr)
        return 2
    topics = _names(args.topics)
    opts = PlayOptions(rate=args.rate, start=args.start, duration=args.duration, loop=args.loop, remap=remap,
                       topics=frozenset(topics) if topics else None, clock=not args.no_clock,
                       wait_for=tuple(_names(args.wait_for)), wait_timeout=args.wait_timeout, delay=args.delay)
    first = [records]

    def source():
        return first.pop() if first else open_log(args.log, laser_pose=pose)[0]

    from common.bus import Node

    node = Node("play", use_sim_time=False)
    try:
        player = Player(node, source, info, opts, progress=None if args.quiet else sys.stderr)
        try:
            st = player.run()
        except LogError as e:
            print(f"\nzenav play: {e}", file=sys.stderr)
            return 2
        except TimeoutError as e:
            print(f"zenav play: {e}", file=sys.stderr)
            return 1
        finally:
            player.stop()
        per = ", ".join(f"{t} {n}" for t, n in sorted(st.sent.items()))
        print(f"played {st.played_s:.1f} s of log in {st.wall_s:.1f} s wall (x{st.rate_achieved:.2f}); "
              f"{st.messages} messages ({per}), {st.clock_ticks} clock ticks", file=sys.stderr)
        if args.trajectory:
            return save_trajectory(node, args.slam_node, args.trajectory, st.sent[player.bus_topic("scan")])
        return 0
    finally:
        node.close()


def save_trajectory(node, slam_node: str, out: str, scans_sent: int, timeout: float = 60.0) -> int:
    """Fetch ``<slam_node>/trajectory`` (again while it grows towards ``scans_sent``) and write it."""
    from common.bus import ServiceError
    from common.messages import Empty
    from master_side.slam.trajectory import from_message, write_trajectory

    stamps = poses = None
    deadline = time.monotonic() + timeout
    while True:
        try:
            msg = node.call(f"{slam_node}/trajectory", Empty(), timeout=max(1.0, deadline - time.monotonic()))
        except ServiceError as e:
            print(f"zenav play: cannot fetch the trajectory: {e}", file=sys.stderr)
            return 1
        n_before: int | None = None if stamps is None else len(stamps)
        stamps, poses = from_message(msg)
        if len(stamps) >= scans_sent or len(stamps) == n_before or time.monotonic() > deadline:
            break
        time.sleep(1.0)  # scans still on their way to the node: ask again
    try:
        write_trajectory(out, stamps, poses)
    except OSError as e:
        print(f"zenav play: cannot write {out}: {e.strerror or e}", file=sys.stderr)
        return 1
    print(f"wrote {out}: {len(stamps)} poses ({scans_sent} scans sent, "
          f"{scans_sent - len(stamps)} not in the SLAM node's trajectory)", file=sys.stderr)
    return 0
