"""Runs ON a fleet host (``zenav fleet status`` starts it over ssh, in the host's venv, with its zenav.env):
which zenav nodes of the host's robot are alive (liveliness tokens) and how often the given topics
arrive, for ``--seconds``. One JSON line on stdout:

    {"robot": R, "nodes": [...], "robots": {robot: n_nodes}, "rates": {topic: hz}, "peers": n, "error": ""}

It joins the Zenoh network the way the host's agent's own nodes do (the agent's listen ports are
turned into connections, ``common.child_process.child_bus_env``), holds no liveliness token and
publishes nothing.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import threading
import time
from collections import defaultdict
from typing import Any

from common.live_keys import LiveKey, live_key
from common.tcp_linger import open_session


def probe(robot: str, topics: list[str], seconds: float) -> dict:
    import zenoh

    from common.child_process import child_bus_env
    from common.zenoh_config import BusConfig

    env = dict(os.environ)
    env.update(child_bus_env(BusConfig.from_env(env)))
    lock = threading.Lock()
    live: set[tuple[str, str]] = set()
    times: dict[str, list[float]] = defaultdict(list)
    out: dict[str, Any] = {"robot": robot, "nodes": [], "robots": {}, "rates": {}, "peers": 0, "error": ""}
    try:
        session = open_session(BusConfig.from_env(env).to_zenoh())
    except Exception as e:  # noqa: BLE001 - bad config / refused credentials: reported, not raised
        out["error"] = f"cannot open a Zenoh session: {e}"
        return out

    def on_token(s) -> None:
        k = LiveKey.parse(s.key_expr)
        if k is not None and k.kind == "node":
            with lock:
                (live.add if s.kind == zenoh.SampleKind.PUT else live.discard)((k.robot, k.node))

    def on_sample(s) -> None:
        topic = str(s.key_expr).split("/", 2)[2]
        with lock:
            times[topic].append(time.monotonic())

    ents = [session.liveliness().declare_subscriber(live_key("*", "node", "*"), on_token, history=True)]
    ents += [session.declare_subscriber(f"zenav/{robot}/{t}", on_sample) for t in topics if robot]
    t0 = time.monotonic()
    time.sleep(seconds)
    window = time.monotonic() - t0
    with lock:
        out["nodes"] = sorted(n for r, n in live if r == robot)
        robots: dict[str, int] = defaultdict(int)
        for r, _ in live:
            robots[r] += 1
        out["robots"] = dict(robots)
        for t in topics:
            ts = times.get(t, [])
            out["rates"][t] = round((len(ts) - 1) / max(ts[-1] - ts[0], 1e-6), 2) if len(ts) >= 2 else \
                round(len(ts) / window, 2)
    out["peers"] = len(list(session.info.peers_zid())) + len(list(session.info.routers_zid()))
    for ent in ents:
        ent.undeclare()
    session.close()
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m deploy.fleet.probe", description=__doc__.split("\n\n")[0])
    ap.add_argument("--robot", default=os.environ.get("ZENAV_ROBOT", ""))
    ap.add_argument("--topics", default="", help="comma list")
    ap.add_argument("--seconds", type=float, default=2.0)
    a = ap.parse_args(argv)
    res = probe(a.robot, [t for t in a.topics.split(",") if t], a.seconds)
    print(json.dumps(res), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
