"""``zenav monitor``: log a robot's topics to the Rerun viewer (our rviz)."""

from __future__ import annotations

import argparse
import contextlib
import os
import signal
import sys
import threading
import time

from common.argtypes import nonneg, port
from common.tcp_linger import open_session

KEYFRAME_S = 10.0  # with --serve-web: rarely logged entities (the latched map) logged again this often
# with --serve-web: Rerun's gRPC history buffer, what a page opened later takes in before it shows the robot
# as it is (the viewer follows the newest data it has taken in, and takes it in slowly without a GPU). With
# 512 MiB a page opened a minute in was a minute late for good; 2 MiB is about 17 s at the web rates, taken in
# within 21 s by a page opened a minute in (4 MiB: 26-45 s; bench/monitor_live.py, issue 31). It must hold
# more than KEYFRAME_S: the map and the goal are logged again that often, so the history always holds them.
# What a late page lacks is the odometry trail's older part.
HISTORY_LIMIT = "2MiB"

DESCRIPTION = """\
Join the bus as a Zenoh peer (on any machine: robot, master or a laptop) and log one robot's
topics to Rerun: map, costmap layers, footprint, global/local plan, goal, laser scan, depth image
and point cloud, odometry trail, TF frames, cmd_vel and loop-time plots, node states and
move_base state changes. Heavy streams are throttled per entity (--rate; the newest message of
each entity is always logged in the end) so long runs keep the viewer's memory bounded, together
with --memory-limit (and, with --serve-web, --history-limit for this process). Times are the message
stamps (timeline `stamp`: a duration under simulated time, a timestamp under wall time).

Outputs (pick one; default: --spawn when a display is available, else --save):
  --spawn              start the native viewer on this machine
  --connect-viewer URL stream to a running viewer (rerun+http://HOST:9876/proxy)
  --serve-web PORT     serve our page at http://BIND:PORT (--bind, default 127.0.0.1): the Rerun web viewer
                       (from the rerun-sdk wheel; the recording on gRPC --grpc-port) and a top-down map with
                       rviz's "2D Nav Goal" / "2D Pose Estimate" tools, cancel, the move_base state and the
                       "why not moving" line; --token T guards the control endpoints (open the page with
                       ?token=T)
  --save FILE.rrd      write a recording; open later with `rerun FILE.rrd`

--robot '*' (or a pattern such as 'pioneer*') shows every matching robot side by side: each robot's
entities and TF frames under its name (robot1/world/map in frame robot1/map), one column per robot
(map, plots, events); not with --serve-web, whose tools drive one robot.
"""


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser("monitor", help="log a robot's topics to the Rerun viewer",
                              description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    out = p.add_mutually_exclusive_group()
    out.add_argument("--spawn", action="store_true", help="spawn the native Rerun viewer")
    out.add_argument("--connect-viewer", metavar="URL", help="connect to a running viewer")
    out.add_argument("--serve-web", type=port, metavar="PORT", help="serve the web viewer on PORT")
    out.add_argument("--save", metavar="FILE", help="save a .rrd recording")
    p.add_argument("--grpc-port", type=port, default=9876, help="gRPC port used with --serve-web")
    p.add_argument("--bind", default="127.0.0.1", metavar="ADDR",
                   help="address the page listens on with --serve-web (default 127.0.0.1: this machine only; "
                        "0.0.0.0: every interface)")
    p.add_argument("--token", default=os.environ.get("ZENAV_MONITOR_TOKEN") or None,
                   help="with --serve-web: goal / initial pose / cancel need this token (header X-Zenav-Token; "
                        "open the page as http://HOST:PORT/?token=T); default $ZENAV_MONITOR_TOKEN")
    p.add_argument("--follow", action="store_true",
                   help="the map and local views track the robot (Rerun's tracking eye; experimental in "
                        "Rerun 0.41, whose web viewer puts the eye onto the robot); default: the whole map "
                        "seen from above")
    p.add_argument("--rate", action="append", default=[], metavar="TYPE=HZ",
                   help="max logging rate per entity for a message type or a topic, e.g. --rate Costmap=1 "
                        "--rate camera/depth/points=0.5 (0 = every message; repeatable or comma list); with "
                        "--serve-web the defaults are lower (deploy/monitor/pacing.py WEB_RATES: a browser's viewer "
                        "without a GPU falls behind at the native viewer's rates)")
    p.add_argument("--duration", type=nonneg, default=0.0, help="stop after this many seconds (0 = Ctrl-C)")
    p.add_argument("--memory-limit", default="2GiB",
                   help="memory limit of the viewer (spawned, or the page's web viewer); the oldest data is "
                        "dropped beyond it, the newest state of every entity stays")
    p.add_argument("--history-limit", default=HISTORY_LIMIT,
                   help="with --serve-web: the history this process keeps for pages opened later (Rerun's gRPC "
                        "buffer; at the web rates about 0.12 MB/s): the oldest is dropped beyond it, "
                        f"the map and goal are logged again every {KEYFRAME_S:.0f} s so a late page still gets "
                        "them (default %(default)s)")
    p.set_defaults(func=run)
    return p


def parse_rates(items: list[str]) -> dict[str, float]:
    from deploy.monitor.pacing import parse_rates as parse

    try:
        return parse(items)
    except ValueError as e:
        raise SystemExit(f"zenav monitor: {e}") from None


def run(args) -> int:
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):  # first thing: a signal during start-up still ends cleanly
        signal.signal(sig, lambda *_: stop.set())
    rates = parse_rates(args.rate)
    if args.serve_web:  # a browser's viewer: the web budget, then the user's own --rate on top
        from deploy.monitor.pacing import WEB_RATES

        rates = {**WEB_RATES, **rates}

    import zenoh

    from common.zenoh_config import BusConfig
    from deploy.cli.session import one_robot
    from deploy.monitor.monitor import Monitor
    from deploy.monitor.viewer import fit_robots_views, fit_view_to_map, open_recording

    if not (args.spawn or args.connect_viewer or args.serve_web or args.save):
        if os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"):
            args.spawn = True
        else:
            args.save = f"zenav-monitor-{time.strftime('%Y%m%d-%H%M%S')}.rrd"
    pattern = getattr(args, "robot", None) or ""
    if "*" in pattern and args.serve_web:
        raise SystemExit("zenav monitor: --serve-web shows one robot (its tools drive it): --robot NAME")
    if "*" not in pattern:
        one_robot(args)
    cfg = BusConfig.from_env()
    robot = pattern if "*" in pattern else cfg.robot
    web_state = web = None
    state_subs: list = []
    if args.serve_web:
        from deploy.monitor.web_assets import ensure_assets
        from deploy.monitor.webstate import WebState

        assets = ensure_assets()  # before any server starts: a clear error when the wheel lacks them
        web_state = WebState(robot)
    rec, where = open_recording(args, robot, getattr(args, "history_limit", HISTORY_LIMIT))
    session = open_session(cfg.to_zenoh())
    observers = [fit_view_to_map(rec, args) if "*" not in robot else fit_robots_views(rec)]
    if web_state is not None:  # the latched map arrives through the monitor's query, the rest directly
        observers.append(lambda topic, msg: web_state.observe(topic, msg) if topic == "map" else None)
    # the page's gRPC server drops its oldest history beyond --memory-limit: log the map, goal and plan again
    # while unchanged so a page opened late still gets them (not for a file or a viewer, which keep them)
    mon = Monitor(session, robot, rec, rates, observers=observers,
                  keyframe_period=KEYFRAME_S if args.serve_web else 0.0)
    if web_state is not None:
        from deploy.monitor.commands import bus_commands
        from deploy.monitor.webserver import WebServer, subscribe_state

        state_subs = subscribe_state(session, robot, web_state)
        try:
            commands = bus_commands(session, robot, on_mission=web_state.mission_line)
            web = WebServer(web_state, commands, args.serve_web, args.grpc_port, args.bind,
                            args.token, args.memory_limit, assets)
        except OSError as e:
            mon.close()
            session.close()
            raise SystemExit(f"zenav monitor: cannot serve the page on {args.bind}:{args.serve_web}: {e}") from None
    print(f"zenav monitor: robot '{robot}', {where}. Ctrl-C to stop.", file=sys.stderr, flush=True)
    deadline = time.monotonic() + args.duration if args.duration > 0 else None
    while not stop.is_set():
        left = 1.0 if deadline is None else deadline - time.monotonic()
        if left <= 0:
            break
        stop.wait(min(left, 1.0))
    if web is not None:
        web.close()
        commands.node.close()
    for h in state_subs:
        with contextlib.suppress(zenoh.ZError):
            h.undeclare()
    mon.close()  # logs what the throttle still held
    session.close()
    rec.flush()
    if args.save:
        rec.disconnect()  # closes the file sink: the .rrd gets its footer
    print(f"zenav monitor: {mon.stats.line()}", file=sys.stderr, flush=True)
    if args.save:
        print(f"zenav monitor: recording saved; view it with `rerun {args.save}` or serve it to a browser "
              f"with `rerun --serve-web {args.save}`", file=sys.stderr)
    return 0
