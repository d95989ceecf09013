"""``zenav topic list | echo | hz`` — like rostopic, over liveliness tokens and plain subscriptions."""

from __future__ import annotations

import dataclasses
import math
import sys
import threading
import time
from collections import defaultdict, deque

from common.argtypes import nonneg_int, positive, positive_int
from common.live_keys import LiveKey, live_key
from deploy.cli.session import one_robot, open_session, robot_pattern, wait


def add_parser(subparsers):
    p = subparsers.add_parser(
        "topic",
        help="list topics, print messages, measure rates",
        description="Inspect topics zenav/<robot>/<topic> (like rostopic).",
    )
    sp = p.add_subparsers(dest="topic_cmd", metavar="SUBCOMMAND", required=True)
    ls = sp.add_parser(
        "list",
        help="topics with type, publishers and rate",
        description="Topics from the publishers' liveliness tokens plus a short passive listen "
        "on zenav/<robot>/** (type and rate of what is flowing). --robot '*' = all.",
    )
    ls.add_argument("--wait", type=positive, default=1.0, metavar="S", help="listen this long (default 1 s)")
    ls.set_defaults(func=run_list)
    ec = sp.add_parser(
        "echo",
        help="print messages as one-line summaries",
        description="Decode every message of TOPIC (any registered type) and print a one-line "
        "summary; arrays as dtype[shape] min..max.",
    )
    ec.add_argument("topic")
    ec.add_argument("-n", type=nonneg_int, default=0, metavar="N", help="exit after N messages")
    ec.add_argument("--duration", type=positive, default=None, metavar="S", help="exit after S seconds")
    ec.set_defaults(func=run_echo)
    hz = sp.add_parser(
        "hz",
        help="publishing rate of a topic",
        description="Receive rate of TOPIC over the last --window messages, with min/max/std "
        "of the period (like rostopic hz). Printed every second.",
    )
    hz.add_argument("topic")
    hz.add_argument(
        "--window", type=positive_int, default=100, metavar="N", help="messages in the window (default 100)"
    )
    hz.add_argument("--duration", type=positive, default=None, metavar="S", help="exit after S seconds")
    hz.set_defaults(func=run_hz)
    return p


# -- helpers ---------------------------------------------------------------------------------------
def _fmt_float(v: float) -> str:
    if not math.isfinite(v):
        return str(v)
    return f"{v:.3f}" if abs(v) >= 1e5 else f"{v:.6g}"  # stamps keep their milliseconds


def summarize(v, depth: int = 0) -> str:
    """A compact one-line rendering: arrays as dtype[shape] min..max, long sequences elided."""
    import numpy as np  # here, not at import: `zenav --help` stays without numpy

    if isinstance(v, np.ndarray):
        s = f"{v.dtype.name}{list(v.shape)}"
        if v.size and v.dtype.kind in "fiu":
            fin = v[np.isfinite(v)] if v.dtype.kind == "f" else v
            if fin.size:
                s += f" {_fmt_float(float(fin.min()))}..{_fmt_float(float(fin.max()))}"
            bad = v.size - fin.size
            if bad:
                s += f" ({bad} non-finite)"
        return s
    if dataclasses.is_dataclass(v) and not isinstance(v, type):
        name = getattr(type(v), "_msg_name", type(v).__name__)
        if depth > 2:
            return f"{name}(…)"
        inner = " ".join(
            f"{f.name}={summarize(getattr(v, f.name), depth + 1)}" for f in dataclasses.fields(v)
        )
        return f"{name}({inner})" if depth else inner
    if isinstance(v, (tuple, list)):
        head = ", ".join(summarize(x, depth + 1) for x in v[:2])
        return f"[{len(v)}: {head}{', …' if len(v) > 2 else ''}]"
    if isinstance(v, float):
        return _fmt_float(v)
    if isinstance(v, str):
        return repr(v if len(v) <= 60 else v[:57] + "...")
    return repr(v)


def _subscribe(session, key: str, on_payload, latched_too: bool = True):
    """A subscriber on ``key`` calling ``on_payload(bytes, publisher)``; also asks latched publishers."""
    import zenoh

    def pub_of(att) -> str:
        return att.to_bytes().decode(errors="replace") if att is not None else "?"

    sub = session.declare_subscriber(key, lambda s: on_payload(s.payload.to_bytes(), pub_of(s.attachment)))
    if latched_too:

        def on_reply(r):
            if r.ok is not None:
                on_payload(r.ok.payload.to_bytes(), pub_of(r.ok.attachment))

        session.get(key, on_reply, target=zenoh.QueryTarget.ALL)
    return sub


def _topic_key(args) -> tuple[str, str]:
    from common.bus import topic_key

    pattern = getattr(args, "robot", None) or ""
    robot = robot_pattern(args, all_by_default=False) if "*" in pattern else one_robot(args)
    return robot, topic_key(robot, args.topic)


# -- list ------------------------------------------------------------------------------------------
def run_list(args) -> int:
    import zenoh

    from common.bus import close_quietly
    from common.codec import peek_type

    robot = robot_pattern(args, all_by_default=True)
    pubs: dict[tuple[str, str], set[str]] = defaultdict(set)  # (robot, topic) -> publisher nodes
    types: dict[tuple[str, str], str] = {}
    counts: dict[tuple[str, str], int] = defaultdict(int)
    lock = threading.Lock()

    def on_token(s: zenoh.Sample) -> None:
        key = LiveKey.parse(s.key_expr)
        if key is not None and key.topic:
            with lock:
                k = (key.robot, key.topic)
                (pubs[k].add if s.kind == zenoh.SampleKind.PUT else pubs[k].discard)(key.node)

    def on_data(s: zenoh.Sample) -> None:

        parts = str(s.key_expr).split("/", 2)  # zenav/<robot>/<topic>
        if len(parts) == 3 and not parts[2].startswith("srv/"):
            with lock:
                k = (parts[1], parts[2])
                counts[k] += 1
                if k not in types:
                    types[k] = peek_type(s.payload.to_bytes())

    session = open_session()
    tok = data = None
    try:
        tok = session.liveliness().declare_subscriber(live_key(robot, "pub", "**"), on_token, history=True)
        data = session.declare_subscriber(f"zenav/{robot}/**", on_data)
        t0 = time.monotonic()
        wait(threading.Event(), args.wait)
        elapsed = time.monotonic() - t0
        with lock:  # latched topics that were silent during the listen: ask their publishers
            silent = [k for k in pubs if k not in types]
        for k in silent:
            for r in session.get(f"zenav/{k[0]}/{k[1]}", target=zenoh.QueryTarget.ALL, timeout=1.0):
                if r.ok is not None:
                    types[k] = peek_type(r.ok.payload.to_bytes())
                    break
        with lock:
            keys = sorted(set(pubs) | set(types))
            rows = [
                (
                    r,
                    t,
                    types.get((r, t), "-"),
                    f"{counts[(r, t)] / elapsed:.1f}" if counts.get((r, t)) else "-",
                    ",".join(sorted(pubs.get((r, t), ()))) or "?",
                )
                for r, t in keys
            ]
    finally:
        close_quietly(tok, data, session)
    if not rows:
        print(f"no topics for robot '{robot}'", file=sys.stderr)
        return 0
    head = ("ROBOT", "TOPIC", "TYPE", "HZ", "PUBLISHERS")
    widths = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(head)]
    for r in (head, *rows):
        print("  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip())
    return 0


# -- echo ------------------------------------------------------------------------------------------
def run_echo(args) -> int:
    from common.bus import close_quietly
    from common.codec import DecodeError, decode

    robot, key = _topic_key(args)
    stop = threading.Event()
    lock = threading.Lock()
    state = {"n": 0, "seen_latched": False}

    def on_payload(data: bytes, publisher: str) -> None:

        with lock:
            if stop.is_set():
                return
            try:
                msg = decode(data)
                line = f"{type(msg)._msg_name} {summarize(msg)}"
            except DecodeError as e:
                print(f"<malformed payload from {publisher}: {e}>", file=sys.stderr, flush=True)
                return
            try:
                print(line, flush=True)
            except BrokenPipeError:
                stop.set()
                return
            state["n"] += 1
            if args.n and state["n"] >= args.n:
                stop.set()

    session = open_session()
    sub = None
    try:
        sub = _subscribe(session, key, on_payload)
        wait(stop, args.duration)
    finally:
        stop.set()
        close_quietly(sub, session)
    return 0


# -- hz --------------------------------------------------------------------------------------------
class RateWindow:
    """Arrival times of the last ``window`` messages -> rate and period statistics (like rostopic hz)."""

    def __init__(self, window: int) -> None:
        self.times: deque[float] = deque(maxlen=max(2, window + 1))
        self.total = 0

    def add(self, t: float) -> None:
        self.times.append(t)
        self.total += 1

    def stats(self) -> dict | None:
        import numpy as np

        if len(self.times) < 2:
            return None
        d = np.diff(np.asarray(self.times))
        return {
            "rate": 1.0 / float(d.mean()) if d.mean() > 0 else float("inf"),
            "min": float(d.min()),
            "max": float(d.max()),
            "std": float(d.std()),
            "window": len(d),
        }


def run_hz(args) -> int:
    from common.bus import close_quietly
    robot, key = _topic_key(args)
    win = RateWindow(args.window)
    lock = threading.Lock()

    def on_payload(data: bytes, publisher: str) -> None:

        with lock:
            win.add(time.monotonic())

    session = open_session()
    sub = None
    stop = threading.Event()
    end = None if args.duration is None else time.monotonic() + args.duration
    try:
        sub = _subscribe(session, key, on_payload, latched_too=False)
        print(f"subscribed to [{key}]", flush=True)
        while end is None or time.monotonic() < end:
            wait(stop, 1.0 if end is None else max(0.0, min(1.0, end - time.monotonic())))
            with lock:
                st, last = win.stats(), (win.times[-1] if win.times else None)
            if st is None:
                print("no new messages", flush=True)
            elif time.monotonic() - last > max(1.0, 3 * st["max"]):
                print(f"no new messages (last {time.monotonic() - last:.1f} s ago)", flush=True)
            else:
                print(
                    f"average rate: {st['rate']:.3f}\n\tmin: {st['min']:.4f}s max: {st['max']:.4f}s "
                    f"std dev: {st['std']:.5f}s window: {st['window']}",
                    flush=True,
                )
    finally:
        close_quietly(sub, session)
    return 0
