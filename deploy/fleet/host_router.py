"""Runs ON a secured fleet host (the service's command): the host's Zenoh router, then the agent.

    python -m deploy.fleet.host_router ROUTER_JSON5 -- zenav robot --config ...

The router (``router.json5`` from ``zenav fleet install``: usrpwd, the links to other hosts' routers,
the robot's cmd_vel access control) lives in this process; the agent and its nodes are its clients
(zenav.env: ZENAV_MODE=client, ZENAV_CONNECT=<router on loopback>). The agent is started once the router
listens and gets SIGTERM when this process is asked to stop or dies (PR_SET_PDEATHSIG); the exit status
is the agent's (2, a bad config, is not restarted by systemd / the supervisor). docs/fleet.md.
"""

from __future__ import annotations

import contextlib
import ctypes
import json
import signal
import subprocess
import sys
import threading

from common.tcp_linger import open_session


def _pdeathsig() -> None:  # the agent gets SIGTERM (it stops its nodes) when its router process dies
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None).prctl(1, signal.SIGTERM, 0, 0, 0)


def main(argv: list[str]) -> int:
    if len(argv) < 3 or argv[1] != "--":
        print(__doc__, file=sys.stderr)
        return 2
    import zenoh

    path, agent = argv[0], argv[2:]
    try:
        conf = zenoh.Config.from_file(path)
        conf.insert_json5("mode", '"router"')
        session = open_session(conf)
    except Exception as e:  # noqa: BLE001 - zenoh raises ZError: a missing file / bad config, a port in use
        print(f"host_router: cannot start the Zenoh router from {path}: {e}", file=sys.stderr, flush=True)
        return 1
    listen = json.loads(conf.get_json("listen/endpoints") or "[]")
    connect = json.loads(conf.get_json("connect/endpoints") or "[]")
    print(f"host_router: router {session.zid()} listening on {listen}, linking to {connect or 'none'}", flush=True)
    stop = threading.Event()
    child: list[subprocess.Popen] = []

    def on_term(*_a) -> None:
        stop.set()
        for c in child:
            with contextlib.suppress(ProcessLookupError):
                c.send_signal(signal.SIGTERM)

    signal.signal(signal.SIGTERM, on_term)
    signal.signal(signal.SIGINT, on_term)
    try:
        if stop.is_set():
            return 0
        child.append(subprocess.Popen(agent, preexec_fn=_pdeathsig))
        if stop.is_set():  # asked to stop while it started
            child[0].send_signal(signal.SIGTERM)
        code = child[0].wait()
    finally:  # the agent is gone: close the router, but never hang the service's stop on it
        closer = threading.Thread(target=session.close, daemon=True)
        closer.start()
        closer.join(5.0)
    return code if code >= 0 else 0 if stop.is_set() else 128 - code


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
