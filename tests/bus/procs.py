"""Child processes for the bus tests: ``python tests/bus/procs.py ROLE [options]``.

The bus config comes from the environment (ZENAV_*), as for every zenav process. Each role prints
one line per event on stdout (flushed) so the test can wait on conditions instead of sleeping.
"""

from __future__ import annotations

import argparse
import json
import sys
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

import numpy as np  # noqa: E402

from common.bus import Node, list_live  # noqa: E402
from common.messages import Header, LaserScan, Text  # noqa: E402


def say(*parts) -> None:
    """One line in one write: print() writes each part separately, and with PYTHONUNBUFFERED each part
    is its own write(2), so lines printed by a callback thread and the main thread could interleave
    ("MSGREADY 12 listener")."""
    sys.stdout.write(" ".join(map(str, parts)) + "\n")
    sys.stdout.flush()


def make_scan(seq: int, beams: int, stamp: float = 0.0) -> LaserScan:
    ranges = np.full(beams, 1.0 + (seq % 100) * 0.01, np.float32)
    ranges[seq % beams] = np.inf
    return LaserScan(
        Header(stamp, f"laser#{seq}"),
        -np.pi,
        np.pi,
        2 * np.pi / beams,
        0.0,
        0.1,
        0.05,
        30.0,
        ranges,
        np.zeros(beams, np.float32),
    )


def scan_sub(a) -> int:
    """Queue-mode subscriber: announces 'ready' (latched) once subscribed, receives N scans, checks them."""
    node = Node("scan_sub")
    sub = node.subscribe("scan", LaserScan, mode="queue", queue_size=a.n + 10)
    bye = node.subscribe("bye", Text)  # before 'done' goes out, so the publisher's 'bye' finds it declared
    ready = node.publisher("ready", latched=True)
    ready.publish(Text(Header(time.time()), "ready"))
    seqs, bad = [], 0
    deadline = time.monotonic() + a.timeout
    try:
        while len(seqs) < a.n and time.monotonic() < deadline:
            try:
                msg = sub.get(timeout=1.0)
            except TimeoutError:
                continue
            seqs.append(int(msg.header.frame_id.split("#")[1]))
            if msg.ranges.shape != (a.beams,) or np.isinf(msg.ranges).sum() != 1:
                bad += 1
        done = node.publisher("done", latched=True)
        done.publish(Text(Header(time.time()), str(len(seqs))))
        say(
            json.dumps(
                {
                    "received": len(seqs),
                    "in_order": seqs == list(range(len(seqs))),
                    "bad": bad,
                    "dropped": sub.dropped,
                    "malformed": sub.malformed,
                }
            )
        )
        # Let the publisher read 'done' (it waits for it) before the session goes away: until its 'bye',
        # or until it has left the bus (it closes right after 'bye'; subscribing to 'bye' only now, as
        # before, raced with that close and then waited the whole 10 s, seen under load).
        end = time.monotonic() + 10.0
        while not bye.received and time.monotonic() < end:
            if f"{node.robot}/node/scan_pub" not in list_live(node.session, node.robot, timeout=0.5):
                break
            time.sleep(0.02)
    finally:
        node.close()
    return 0


def scan_pub(a) -> int:
    """Waits until the subscriber is matched and ready, then publishes N scans reliably."""
    node = Node("scan_pub")
    pub = node.publisher("scan", reliable=True)  # a lossless burst: block while the queue is full
    bye = node.publisher("bye", latched=True)
    node.subscribe("ready", Text).wait_first(timeout=a.timeout)
    deadline = time.monotonic() + a.timeout
    while not pub._pub.matching_status.matching:  # the subscriber's declaration reached us
        if time.monotonic() > deadline:
            say(json.dumps({"error": "subscriber never matched"}))
            return 1
        time.sleep(0.01)
    done = node.subscribe("done", Text)
    for i in range(a.n):
        pub.publish(make_scan(i, a.beams, time.time()))
    msg = done.wait_first(timeout=a.timeout)
    bye.publish(Text(Header(), "bye"))
    say(json.dumps({"sent": a.n, "subscriber_got": int(msg.data)}))
    node.close()
    return 0


def node_proc(a) -> int:
    """A node that publishes 'chatter' at 10 Hz until killed."""
    node = Node(a.name)
    pub = node.publisher("chatter")
    n = [0]

    def tick() -> None:
        n[0] += 1
        pub.publish(Text(Header(time.time(), f"#{n[0]}"), "hello"))

    node.timer(0.1, tick)
    say("READY", a.name)
    threading.Event().wait()
    return 0


def talker(a) -> int:
    """Publishes LaserScans on 'scan' at --rate Hz until killed."""
    node = Node(a.name)
    pub = node.publisher("scan")
    i = [0]

    def tick() -> None:
        pub.publish(make_scan(i[0], a.beams, time.time()))
        i[0] += 1

    node.timer(1.0 / a.rate, tick)
    say("READY", a.name)
    threading.Event().wait()
    return 0


def listener(a) -> int:
    """Prints 'MSG <seq>' per scan and 'LIVE +|- <key> <time.time()>' per liveliness change of nodes."""
    import zenoh

    node = Node(a.name)

    def on_token(s: zenoh.Sample) -> None:
        sign = "+" if s.kind == zenoh.SampleKind.PUT else "-"
        say("LIVE", sign, str(s.key_expr), f"{time.time():.6f}")

    node.session.liveliness().declare_subscriber(f"zenavlive/{node.robot}/node/*", on_token, history=True)
    node.subscribe(
        "scan", LaserScan, callback=lambda m: say("MSG", m.header.frame_id.split("#")[1]), mode="queue"
    )
    say("READY", a.name)
    threading.Event().wait()
    return 0


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("role", choices=("scan_sub", "scan_pub", "node", "talker", "listener"))
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--beams", type=int, default=720)
    ap.add_argument("--rate", type=float, default=20.0)
    ap.add_argument("--name", default="proc")
    ap.add_argument("--timeout", type=float, default=60.0)
    a = ap.parse_args()
    fn = {
        "scan_sub": scan_sub,
        "scan_pub": scan_pub,
        "node": node_proc,
        "talker": talker,
        "listener": listener,
    }[a.role]
    return fn(a)


if __name__ == "__main__":
    sys.exit(main())
