"""``zenav nodes`` — nodes alive on the bus, from their liveliness tokens (like rosnode list)."""

from __future__ import annotations

import sys
import threading
import time
from collections import defaultdict

from common.argtypes import positive
from common.live_keys import LiveKey, live_key
from deploy.cli.session import open_session, robot_pattern, wait


def add_parser(subparsers):
    p = subparsers.add_parser(
        "nodes",
        help="nodes alive on the bus (liveliness)",
        description="Nodes from their liveliness tokens zenavlive/<robot>/node/<name>. A node whose process "
        "dies or whose machine is cut off disappears within about a second (link lease). "
        "--robot '*' (default without $ZENAV_ROBOT) = all robots.",
    )
    p.add_argument(
        "--watch",
        action="store_true",
        help="keep running and print '+ robot node' / '- robot node' as nodes appear and disappear",
    )
    p.add_argument(
        "-l", "--long", action="store_true", help="also list each node's publications and services"
    )
    p.add_argument(
        "--stats", action="store_true",
        help="ask every node for its subscriptions' counters: received, malformed (not the type), invalid "
        "(NaN, zero quaternion, empty map...), dropped (replaced before use), callback errors")
    p.add_argument(
        "--wait",
        type=positive,
        default=1.0,
        metavar="S",
        help="how long to collect tokens before printing the list (default 1 s)",
    )
    p.add_argument("--duration", type=positive, default=None, metavar="S", help="--watch: exit after S seconds")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    import zenoh

    from common.bus import close_quietly

    robot = robot_pattern(args, all_by_default=True)
    lock = threading.Lock()
    live: set[tuple[str, str, str, str]] = set()
    ready = threading.Event()  # --watch: history is printed as the initial list, then events

    def on_token(s: zenoh.Sample) -> None:

        item = LiveKey.parse(s.key_expr)
        if item is None:
            return
        with lock:
            if s.kind == zenoh.SampleKind.PUT:
                live.add(item)
            else:
                live.discard(item)
            if args.watch and ready.is_set() and item[1] == "node":
                sign = "+" if s.kind == zenoh.SampleKind.PUT else "-"
                stamp = time.strftime("%H:%M:%S") + f".{int(time.time() * 1000) % 1000:03d}"
                print(f"{stamp} {sign} {item[0]} {item[2]}", flush=True)

    session = open_session()
    sub = None
    try:
        key = live_key(robot, "**", "") if args.long else live_key(robot, "node", "*")
        sub = session.liveliness().declare_subscriber(key, on_token, history=True)
        wait(threading.Event(), args.wait)
        with lock:
            if args.stats:
                _print_stats(session, sorted({(r, n) for r, k, n, _ in live if k == "node"}))
            else:
                _print_list(live, args.long)
            ready.set()
        if args.watch:
            wait(threading.Event(), args.duration)
    finally:
        close_quietly(sub, session)
    return 0


def _print_list(live: set, long: bool) -> None:
    nodes = sorted({(r, n) for r, k, n, _ in live if k == "node"})
    if not nodes:
        print("no nodes", file=sys.stderr, flush=True)
    details: dict[tuple[str, str], list[str]] = defaultdict(list)
    for r, k, n, name in sorted(live):
        if k != "node" and name:
            details[(r, n)].append(f"{k}:{name}")
    for r, n in nodes:
        line = f"{r}  {n}"
        if long and details[(r, n)]:
            line += "  " + " ".join(details[(r, n)])
        print(line, flush=True)


def _print_stats(session, nodes: list[tuple[str, str]]) -> None:
    """One line per node and subscription, from each node's ``node_stats/<node>`` service."""
    import zenoh

    from common.codec import DecodeError, decode, encode
    from common.messages import Empty, NodeStats

    if not nodes:
        print("no nodes", file=sys.stderr, flush=True)
        return
    print(f"{'robot':12} {'node':22} {'topic':30} {'type':22} {'received':>9} {'malformed':>9} {'invalid':>8} "
          f"{'dropped':>8} {'errors':>6}")
    for robot, name in nodes:
        stats = None
        for reply in session.get(f"zenav/{robot}/srv/node_stats/{name}", payload=encode(Empty()), timeout=2.0,
                                 target=zenoh.QueryTarget.BEST_MATCHING):
            if reply.ok is not None:
                try:
                    stats = decode(reply.ok.payload.to_bytes(), NodeStats)
                except DecodeError:
                    stats = None
        if stats is None:
            print(f"{robot:12} {name:22} (no answer)", flush=True)
            continue
        for t in stats.topics or ():
            print(f"{robot:12} {name:22} {t.topic:30} {t.msg_type:22} {t.received:9d} {t.malformed:9d} "
                  f"{t.invalid:8d} {t.dropped:8d} {t.errors:6d}", flush=True)
        if not stats.topics:
            print(f"{robot:12} {name:22} (no subscriptions)", flush=True)
