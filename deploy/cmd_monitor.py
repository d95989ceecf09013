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

KEYFRAME_S = 30.0  # with --serve-web: rarely logged entities (the latched map) logged again this often
HISTORY_LIMIT = "512MiB"  # with --serve-web: Rerun's gRPC history buffer (bench/monitor_memory.py)

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
                        "--rate camera/depth/points=0.5 (0 = every message; repeatable or comma list)")
    p.add_argument("--duration", type=nonneg, default=0.0, help="stop after this many seconds (0 = Ctrl-C)")
    p.add_argument("--memory-limit", default="2GiB",
                   help="memory limit of the viewer (spawned, or the page's web viewer); the oldest data is "
                        "dropped beyond it, the newest state of every entity stays")
    p.add_argument("--history-limit", default=HISTORY_LIMIT,
                   help="with --serve-web: the history this process keeps for pages opened later (Rerun's gRPC "
                        "buffer; at the demo's rates about 1 MB/s is offered): the oldest is dropped beyond it, "
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


def open_recording(args, robot: str):
    """A Rerun recording stream with the sink the user asked for; returns (rec, description)."""
    import rerun as rr

    from deploy.monitor.layout import blueprint

    rec = rr.RecordingStream(f"zenav_{robot}".replace("*", "all"))
    bp = blueprint(follow=getattr(args, "follow", False)) if "*" not in robot else robots_blueprint({})
    if args.save:
        parent = os.path.dirname(os.path.abspath(args.save))
        if not os.path.isdir(parent) or not os.access(parent, os.W_OK):
            raise ValueError(f"cannot write the recording {args.save}: {parent} is not a writable folder")
        try:
            rec.save(args.save, default_blueprint=bp)
        except RuntimeError as e:  # rerun reports file errors as RuntimeError
            raise ValueError(f"cannot write the recording {args.save}: {e}") from None
        return rec, f"saving to {args.save} (open with: rerun {args.save})"
    if args.serve_web:
        uri = rec.serve_grpc(grpc_port=args.grpc_port, default_blueprint=bp,
                             server_memory_limit=getattr(args, "history_limit", HISTORY_LIMIT))
        host = args.bind if args.bind not in ("0.0.0.0", "::") else "localhost"
        return rec, f"page at http://{host}:{args.serve_web}/ (recording {uri})"
    if args.connect_viewer:
        rec.connect_grpc(args.connect_viewer, default_blueprint=bp)
        return rec, f"streaming to {args.connect_viewer}"
    rec.spawn(memory_limit=args.memory_limit, default_blueprint=bp)
    return rec, "spawned the Rerun viewer"


def fit_view_to_map(rec, args):
    """An observer that sends the blueprint again, the map view fitted to the map, when it first arrives."""
    from common.messages import OccupancyGrid
    from deploy.monitor.layout import blueprint, fit_height

    done = []

    def observe(topic: str, msg) -> None:
        if done or topic != "map" or not isinstance(msg, OccupancyGrid) or msg.width == 0:
            return
        done.append(True)
        w, h = msg.width * msg.resolution, msg.height * msg.resolution
        centre = (msg.origin.x + w / 2, msg.origin.y + h / 2)  # (map origins are not rotated in practice)
        rec.send_blueprint(blueprint(follow=getattr(args, "follow", False), centre=centre,
                                     height=fit_height(w, h)), make_active=True)

    return observe


def robots_blueprint(maps: dict[str, tuple]) -> object:
    """Side by side, one column per robot (``maps``: robot -> (centre, eye height) of its map view)."""
    import rerun.blueprint as rrb

    from deploy.monitor.layout import top_down

    def column(r: str, centre: tuple, height: float):
        return rrb.Vertical(
            rrb.Spatial3DView(name=f"{r}: map", origin="/", contents=[f"/{r}/world/**", f"/{r}/tf/**"],
                              spatial_information=rrb.SpatialInformation(target_frame=f"{r}/map"),
                              eye_controls=top_down(centre, height, False), line_grid=False),
            rrb.TimeSeriesView(name=f"{r}: plots", origin=f"/{r}/plots"),
            rrb.TextLogView(name=f"{r}: events", origin=f"/{r}/log"), row_shares=[3, 2, 2])

    cols = [column(r, *maps[r]) for r in sorted(maps)] or [rrb.TextDocumentView(name="waiting for robots")]
    return rrb.Blueprint(rrb.Horizontal(*cols), collapse_panels=True)


def fit_robots_views(rec):
    """For a robot pattern: an observer sending the side-by-side blueprint again when a robot first shows
    up and when its map first arrives (its view fitted to the map)."""
    from common.messages import OccupancyGrid
    from deploy.monitor.layout import DEFAULT_HEIGHT, fit_height

    maps: dict[str, tuple] = {}
    fitted: set[str] = set()

    def observe(topic: str, msg) -> None:
        robot, _, topic = topic.partition("/")
        fit = topic == "map" and isinstance(msg, OccupancyGrid) and msg.width > 0 and robot not in fitted
        if robot in maps and not fit:
            return
        maps[robot] = ((0.0, 0.0), DEFAULT_HEIGHT)
        if fit:
            fitted.add(robot)
            w, h = msg.width * msg.resolution, msg.height * msg.resolution
            maps[robot] = ((msg.origin.x + w / 2, msg.origin.y + h / 2), fit_height(w, h))
        rec.send_blueprint(robots_blueprint(maps), make_active=True)

    return observe


def bus_commands(session, robot: str, deadline: float = 20.0):
    """``send(what, msg)`` for the page's tools: each command acknowledged by the node that acts on it
    (common/delivery.py), so the page says "accepted by move_base" or who did not answer — never a
    silent put into a link that is down."""
    import uuid

    from common.bus import Node, ServiceError
    from common.delivery import DeliveryFailed, cancel_goal, send_acknowledged, send_goal
    from common.messages import GoalStatus, MoveBaseGoal, PoseStamped
    from deploy.monitor.webserver import CommandNotAcknowledged

    node = Node(f"monitor_web_{uuid.uuid4().hex[:6]}", robot=robot, session=session)

    def send(what: str, msg) -> str:
        try:
            if what == "goal":
                gid = f"web-{uuid.uuid4().hex[:8]}"
                st = send_goal(node, MoveBaseGoal(gid, msg), deadline)
                if st.status == GoalStatus.REJECTED:
                    raise ValueError(f"move_base rejected the goal: {st.reason}")
                return f"goal {gid} accepted by move_base"
            if what == "cancel":
                st = cancel_goal(node, "", deadline)
                return f"cancel acknowledged by move_base ({st.goal_id or 'no goal'})"
            pose = send_acknowledged(node, "set_initial_pose", msg, PoseStamped, deadline,
                                     what=f"AMCL of robot '{robot}'").pose.to_pose2d()
            return f"AMCL set its pose to ({pose.x:.2f}, {pose.y:.2f})"
        except DeliveryFailed as e:
            raise CommandNotAcknowledged(str(e)) from None
        except ServiceError as e:  # the node answered: no (e.g. AMCL without a map yet)
            raise ValueError(str(e)) from None

    send.node = node  # closed with the monitor
    return send


def run(args) -> int:
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):  # first thing: a signal during start-up still ends cleanly
        signal.signal(sig, lambda *_: stop.set())
    rates = parse_rates(args.rate)

    import zenoh

    from common.zenoh_config import BusConfig
    from deploy import one_robot
    from deploy.monitor.monitor import Monitor

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
    rec, where = open_recording(args, robot)
    session = zenoh.open(cfg.to_zenoh())
    observers = [fit_view_to_map(rec, args) if "*" not in robot else fit_robots_views(rec)]
    if web_state is not None:  # the latched map arrives through the monitor's query, the rest directly
        observers.append(lambda topic, msg: web_state.observe(topic, msg) if topic == "map" else None)
    # the page's gRPC server drops its oldest history beyond --memory-limit: log the map, goal and plan again
    # while unchanged so a page opened late still gets them (not for a file or a viewer, which keep them)
    mon = Monitor(session, robot, rec, rates, observers=observers,
                  keyframe_period=KEYFRAME_S if args.serve_web else 0.0)
    if web_state is not None:
        from deploy.monitor.webserver import WebServer, subscribe_state

        state_subs = subscribe_state(session, robot, web_state)
        try:
            commands = bus_commands(session, robot)
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
