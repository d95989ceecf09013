"""``zenav monitor``: log a robot's topics to the Rerun viewer (our rviz)."""

from __future__ import annotations

import argparse
import os
import signal
import sys
import threading
import time

DESCRIPTION = """\
Join the bus as a Zenoh peer (on any machine: robot, master or a laptop) and log one robot's
topics to Rerun: map, costmap layers, footprint, global/local plan, goal, laser scan, depth image
and point cloud, odometry trail, TF frames, cmd_vel and loop-time plots, node states and
move_base state changes. Heavy streams are throttled per message type (--rate) so long runs keep
the viewer's memory bounded.

Outputs (pick one; default: --spawn when a display is available, else --save):
  --spawn              start the native viewer on this machine
  --connect-viewer URL stream to a running viewer (rerun+http://HOST:9876/proxy)
  --serve-web PORT     serve the web viewer at http://localhost:PORT (gRPC on --grpc-port)
  --save FILE.rrd      write a recording; open later with `rerun FILE.rrd`
"""


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser("monitor", help="log a robot's topics to the Rerun viewer",
                              description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    out = p.add_mutually_exclusive_group()
    out.add_argument("--spawn", action="store_true", help="spawn the native Rerun viewer")
    out.add_argument("--connect-viewer", metavar="URL", help="connect to a running viewer")
    out.add_argument("--serve-web", type=int, metavar="PORT", help="serve the web viewer on PORT")
    out.add_argument("--save", metavar="FILE", help="save a .rrd recording")
    p.add_argument("--grpc-port", type=int, default=9876, help="gRPC port used with --serve-web")
    p.add_argument("--rate", action="append", default=[], metavar="TYPE=HZ",
                   help="max logging rate per message type, e.g. Costmap=1 PointCloud=0.5 (0 = all)")
    p.add_argument("--duration", type=float, default=0.0, help="stop after this many seconds (0 = Ctrl-C)")
    p.add_argument("--memory-limit", default="2GiB", help="viewer memory limit (spawn/serve)")
    p.set_defaults(func=run)
    return p


def parse_rates(items: list[str]) -> dict[str, float]:
    rates = {}
    for item in items:
        name, _, hz = item.partition("=")
        try:
            rates[name.strip()] = float(hz)
        except ValueError:
            raise SystemExit(f"zenav monitor: --rate expects TYPE=HZ, got {item!r}") from None
    return rates


def open_recording(args, robot: str):
    """A Rerun recording stream with the sink the user asked for; returns (rec, description)."""
    import rerun as rr

    from deploy.monitor.monitor import blueprint

    rec = rr.RecordingStream(f"zenav_{robot}")
    bp = blueprint()
    if args.save:
        rec.save(args.save, default_blueprint=bp)
        return rec, f"saving to {args.save} (open with: rerun {args.save})"
    if args.serve_web:
        uri = rec.serve_grpc(grpc_port=args.grpc_port, default_blueprint=bp,
                             server_memory_limit=args.memory_limit)
        rr.serve_web_viewer(web_port=args.serve_web, open_browser=False, connect_to=uri)
        return rec, f"web viewer at http://localhost:{args.serve_web}/?url={uri}"
    if args.connect_viewer:
        rec.connect_grpc(args.connect_viewer, default_blueprint=bp)
        return rec, f"streaming to {args.connect_viewer}"
    rec.spawn(memory_limit=args.memory_limit, default_blueprint=bp)
    return rec, "spawned the Rerun viewer"


def run(args) -> int:
    import zenoh

    from common.zenoh_config import BusConfig
    from deploy.monitor.monitor import Monitor

    if not (args.spawn or args.connect_viewer or args.serve_web or args.save):
        if os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"):
            args.spawn = True
        else:
            args.save = f"zenav-monitor-{time.strftime('%Y%m%d-%H%M%S')}.rrd"
    cfg = BusConfig.from_env()
    robot = cfg.robot
    rec, where = open_recording(args, robot)
    session = zenoh.open(cfg.to_zenoh())
    mon = Monitor(session, robot, rec, parse_rates(args.rate))
    print(f"zenav monitor: robot '{robot}', {where}. Ctrl-C to stop.", file=sys.stderr)
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    t0 = time.monotonic()
    while not stop.wait(1.0):
        if args.duration and time.monotonic() - t0 >= args.duration:
            break
    mon.close()
    rec.flush()
    session.close()
    s = mon.stats
    print(f"zenav monitor: received={s.received} logged={s.logged} throttled={s.throttled} "
          f"malformed={s.malformed}", file=sys.stderr)
    if args.save:
        rec.disconnect() if hasattr(rec, "disconnect") else None
        print(f"zenav monitor: recording saved; view it with `rerun {args.save}` or serve it to a browser "
              f"with `rerun --serve-web {args.save}`", file=sys.stderr)
    return 0
