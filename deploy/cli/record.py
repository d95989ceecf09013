"""``zenav record OUT.mcap``: record a robot's topics into an MCAP file (like ``rosbag record``)."""

from __future__ import annotations

import argparse
import signal
import sys
import threading
import time
from typing import TYPE_CHECKING

from common.argtypes import nonneg, positive
from deploy.cli.session import one_robot, open_session

if TYPE_CHECKING:  # zenoh only when the command runs: `zenav --help` stays fast
    from deploy.logs.recorder import Recorder

DEFAULT_TOPICS = (
    "scan", "odom", "tf", "tf_static", "map", "cmd_vel", "move_base/global_plan", "move_base/local_plan",
    "move_base/current_goal", "move_base_simple/goal", "move_base/goal", "move_base/status", "amcl_pose",
    "global_costmap/costmap", "local_costmap/costmap", "local_costmap/footprint",
)
DEFAULT_RATES = {"Costmap": 2.0}

DESCRIPTION = f"""\
Record topics of one robot into OUT.mcap (open it in Foxglove Studio, or play it with `zenav play`).
Messages with a standard ROS1 type are written as ROS1 (schema encoding ros1msg, message encoding
ros1): LaserScan, Odometry, tf / tf_static (tf2_msgs/TFMessage), OccupancyGrid, costmaps (as
nav_msgs/OccupancyGrid, costmap_2d's cost table), Path, DepthImage (sensor_msgs/Image 32FC1), CameraInfo,
Twist, PoseStamped, Clock; every other type in zenav's msgpack encoding, so nothing is lost. Topic names
in the file are ROS style (/scan). Log time = the message stamp (the bus clock when a message has none
or a stale one), publish time = the receive time. Latched topics (map, tf_static) are fetched from
their publishers at once. A progress line goes to stderr; Ctrl-C, SIGTERM or --duration end the
recording with a complete, indexed file.

default topics: {", ".join(DEFAULT_TOPICS)}
default rates: Costmap=2 (Hz, per topic; --rate Costmap=0 records every costmap)

examples:
  zenav record run.mcap --robot pioneer1
  zenav record run.mcap --topics scan,odom,tf,tf_static --duration 60
  zenav record all.mcap --all --rate camera/depth/image=5
"""


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser("record", help="record topics into an MCAP file (ROS1 types for Foxglove)",
                              description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("out", metavar="OUT.mcap", help="file to write (replaced if it exists)")
    which = p.add_mutually_exclusive_group()
    which.add_argument("--topics", action="append", metavar="T1,T2", help="topics to record (repeatable or "
                       "comma list; default: the navigation set below)")
    which.add_argument("--all", action="store_true", help="every topic of the robot, as `zenav topic list` sees")
    p.add_argument("--duration", type=positive, default=None, metavar="S", help="stop after S seconds")
    p.add_argument("--rate", action="append", default=[], metavar="NAME=HZ",
                   help="max recording rate of a topic or message type (0 = every message; repeatable or comma "
                        "list); the newest message of a throttled topic is always written")
    p.add_argument("--compression", choices=("zstd", "lz4", "none"), default="zstd", help="chunk compression")
    p.add_argument("--progress", type=nonneg, default=5.0, metavar="S",
                   help="progress line on stderr every S seconds (0 = none)")
    p.set_defaults(func=run)
    return p


def _progress(rec: Recorder, elapsed: float) -> str:
    stats = sorted(rec.writer.stats.items())
    n = sum(s.messages for _, s in stats)
    mb = sum(s.bytes for _, s in stats) / 1e6
    per = " ".join(f"{t}={s.messages}/{s.bytes / 1e6:.1f}MB" for t, s in stats)
    extra = f" dropped={rec.dropped}" if rec.dropped else ""
    if lost := rec.gaps.total():
        extra += f" lost={lost}"
    return f"zenav record: {elapsed:.0f} s {n} msgs {mb:.1f} MB{extra} | {per or 'nothing yet'}"


def _rates(items: list[str]) -> dict[str, float]:
    """DEFAULT_RATES updated by --rate NAME=HZ; ValueError (one line, exit 2) for a bad one."""
    import math

    from deploy.monitor.pacing import parse_rates

    rates = parse_rates(items)
    bad = [f"{k}={v}" for k, v in rates.items() if not math.isfinite(v)]
    if bad:
        raise ValueError(f"--rate {', '.join(bad)}: HZ must be a finite number >= 0")
    return {**DEFAULT_RATES, **rates}


def run(args) -> int:
    from common.bus import close_quietly
    from deploy.logs.mcap_io import McapLogWriter

    rates = _rates(args.rate)
    topics = None if args.all else [t.strip().strip("/") for v in (args.topics or [",".join(DEFAULT_TOPICS)])
                                    for t in v.split(",") if t.strip().strip("/")]
    if topics is not None and not topics:
        print("zenav record: --topics names no topic", file=sys.stderr)
        return 2
    robot = one_robot(args)
    from common.bus import topic_key

    for t in topics or ():
        topic_key(robot, t)  # ValueError (one line, exit 2) for a bad name
    try:
        writer = McapLogWriter(args.out, compression=args.compression)
    except OSError as e:
        print(f"zenav record: cannot write {args.out}: {e.strerror or e}", file=sys.stderr)
        return 2
    stop = threading.Event()
    old = {s: signal.signal(s, lambda *_: stop.set()) for s in (signal.SIGINT, signal.SIGTERM)}
    session = rec = None
    t0 = time.monotonic()
    try:
        session = open_session()
        from deploy.logs.recorder import Recorder

        rec = Recorder(session, robot, writer, topics, rates)
        rec.start()
        what = "every topic" if topics is None else f"{len(topics)} topics"
        print(f"zenav record: recording {what} of robot '{robot}' into {args.out} "
              f"({'until Ctrl-C' if args.duration is None else f'{args.duration:g} s'})", file=sys.stderr, flush=True)
        t0 = time.monotonic()
        next_line = t0 + args.progress
        while not stop.is_set():
            now = time.monotonic()
            if args.duration is not None and now - t0 >= args.duration:
                break
            if args.progress and now >= next_line:
                print(_progress(rec, now - t0), file=sys.stderr, flush=True)
                next_line = now + args.progress
            stop.wait(0.1)
    finally:
        if rec is not None:
            rec.close()
        writer.close()
        close_quietly(session)
        for s, h in old.items():
            signal.signal(s, h)
    _summary(rec, args.out, topics, time.monotonic() - t0)
    return 0


def _summary(rec: Recorder | None, out: str, topics: list[str] | None, elapsed: float) -> None:
    if rec is None:
        return
    print(_progress(rec, elapsed).replace("zenav record:", f"zenav record: wrote {out}:", 1), file=sys.stderr)
    if rec.malformed:
        print(f"zenav record: {rec.malformed} malformed payload(s) skipped", file=sys.stderr)
    if rec.gaps.lost:
        per = ", ".join(f"{t} {n}" for t, n in sorted(rec.gaps.lost.items()))
        print(f"zenav record: {rec.gaps.total()} message(s) lost on the way, numbered by their publishers but "
              f"never received ({per}): the recorder or its link could not keep up", file=sys.stderr)
    silent = [t for t in topics or () if t not in rec.writer.stats]
    if silent:
        print(f"zenav record: nothing received on {', '.join(silent)}", file=sys.stderr)
