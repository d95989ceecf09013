"""Zenoh's TCP links get a 10 s linger, which makes a close block its routing thread while the link is cut
(common/tcp_linger.py); every session opened through ``open_session`` has them turned off.

Each case runs in a fresh interpreter: a guard already running in this worker (any earlier test's Node
starts one) would turn the lingers off before the test could see them."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

from common.ports import free_port

REPO = Path(__file__).resolve().parents[2]

PAIR = """
import json, time, zenoh
from common import tcp_linger

def conf(listen, connect):
    c = zenoh.Config()
    for key, value in (("mode", "peer"), ("scouting/multicast/enabled", False), ("listen/endpoints", listen),
                       ("connect/endpoints", connect)):
        c.insert_json5(key, json.dumps(value))
    return c

def wait(cond, s=30.0):
    end = time.monotonic() + s
    while not cond() and time.monotonic() < end:
        time.sleep(0.02)
    return cond()

a = OPEN(conf(["tcp/127.0.0.1:{port}"], []))
b = OPEN(conf([], ["tcp/127.0.0.1:{port}"]))
linked = wait(lambda: list(a.info.peers_zid()) and list(b.info.peers_zid()))
"""


def _run(opener: str, body: str) -> dict:
    code = textwrap.dedent(PAIR).replace("{port}", str(free_port())).replace("OPEN", opener) + textwrap.dedent(body)
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=120,
                         env={"PYTHONPATH": str(REPO), "PATH": "/usr/bin:/bin"})
    assert out.returncode == 0, out.stderr[-3000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_zenoh_links_linger_and_one_scan_turns_it_off():
    r = _run("zenoh.open", """
        lingering = tcp_linger.lingering_sockets()
        guard = tcp_linger.LingerGuard()
        n = guard.scan()
        print(json.dumps({"linked": bool(linked), "before": len(lingering), "cleared": n,
                          "after": len(tcp_linger.lingering_sockets()), "again": guard.scan()}))
    """)
    assert r["linked"], "the two sessions never linked"
    # both ends of the one link; if this fails, Zenoh no longer sets a linger and the guard can go
    assert r["before"] == 2, r
    assert (r["cleared"], r["after"], r["again"]) == (2, 0, 0), r


def test_sessions_opened_by_open_session_lose_their_linger_within_a_scan_or_two():
    r = _run("tcp_linger.open_session", """
        cleared = wait(lambda: not tcp_linger.lingering_sockets(), 10.0)
        guard = tcp_linger.start_linger_guard()
        print(json.dumps({"linked": bool(linked), "cleared": cleared, "count": guard.cleared}))
    """)
    assert r["linked"], "the two sessions never linked"
    assert r["cleared"] and r["count"] >= 2, r


def test_a_fork_of_a_guarded_process_starts_its_own_guard():
    r = _run("tcp_linger.open_session", """
        import os
        parent = tcp_linger.start_linger_guard()
        rfd, wfd = os.pipe()
        pid = os.fork()
        if pid == 0:  # threads are not copied into a fork: its guard must be a new one, with its thread
            import threading
            g = tcp_linger.start_linger_guard()
            alive = any(t.name == "tcp-linger-guard" for t in threading.enumerate())
            os.write(wfd, json.dumps({"new": g is not parent, "thread": alive}).encode())
            os._exit(0)
        os.waitpid(pid, 0)
        print(os.read(rfd, 1000).decode())
    """)
    assert r == {"new": True, "thread": True}, r
