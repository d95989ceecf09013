"""One side of the reconnect benchmark (bench/reconnect.py), run inside a network namespace.

    python -m testkit.reconnect_peer master|robot|extra|agent

master: serves what move_base and map_server serve: a ``goal`` topic, an acknowledged ``rc_goal``
        service, a latched ``map`` and a 10 Hz ``status`` stream back to the robot.
extra:  a bystander (``--peers``): publishes a 20 Hz stream and subscribes to the other side's, as the
        many node processes of a real robot and master do (every pair of them holds a Zenoh session)
agent:  an agent's session (children: agent): the side's one peer, listening on the loopback endpoint given
        as the second argument; the other roles of that side then run as its clients (ZENAV_VIA_AGENT)
robot:  reads commands on stdin and sends as the goal senders do:
        ``stream ID``  put ID:0, ID:1, ... on the goal topic every 50 ms until ``stop``
        ``fresh ID``   the same from a publisher declared now (a new sender right after a heal)
        ``call ID``    send ID through the acknowledged service (retrying inside, as `zenav goal` does)
        ``latched ID`` a new subscriber of the latched map (as a recorder started after the heal)
        ``await ID``   ``STATUS ID`` at the first master status that comes after this command (the
                       master -> robot stream over the subscription declared at the start)
Every event is one line: wall time, kind, values (both sides run on one machine: one clock).
"""

from __future__ import annotations

import sys
import threading
import time

from common.bus import Node
from common.messages import Header, Text

_lock = threading.Lock()


def say(*words) -> None:
    with _lock:
        print(f"{time.time():.4f}", *words, flush=True)


def master() -> None:
    node = Node("rc_master", use_sim_time=False)
    node.subscribe("goal", Text, mode="queue", queue_size=1000, callback=lambda m: say("GOT", m.data))

    def serve(req: Text) -> Text:
        say("SRV", req.data)
        return req

    node.service("rc_goal", serve, Text)
    node.publisher("map", latched=True).publish(Text(Header(time.time(), "map"), "the map"))
    status = node.publisher("status")
    node.timer(0.1, lambda: status.publish(Text(Header(time.time(), ""), "status")))
    say("READY")
    sys.stdin.read()  # until the benchmark closes our stdin
    node.close()


def agent() -> None:
    from common.zenoh_config import BusConfig

    node = Node("rc_agent", config=BusConfig.from_env(local_listen=(sys.argv[2],)), use_sim_time=False)
    say("READY")
    sys.stdin.read()
    node.close()


def extra() -> None:
    import os

    node = Node(f"rc_extra_{os.getpid()}", use_sim_time=False)
    pub = node.publisher(f"chatter/{os.getpid()}")
    node.subscribe("status", Text, mode="latest")
    node.timer(0.05, lambda: pub.publish(Text(Header(time.time(), ""), "x" * 200)))
    say("READY")
    sys.stdin.read()
    node.close()


def robot() -> None:
    from common.delivery import send_acknowledged

    node = Node("rc_robot", use_sim_time=False)
    goal = node.publisher("goal")
    awaiting: list[str] = []

    def on_status(_m: Text) -> None:
        while awaiting:
            say("STATUS", awaiting.pop())

    status = node.subscribe("status", Text, mode="latest", callback=on_status)
    streams: dict[str, threading.Event] = {}

    def stream(ident: str, pub) -> None:
        stop = streams[ident] = threading.Event()
        k = 0
        while not stop.wait(0.05):
            pub.publish(Text(Header(time.time(), ""), f"{ident}:{k}"))
            k += 1
        if pub is not goal:
            pub.close()

    def call(ident: str) -> None:
        try:
            send_acknowledged(node, "rc_goal", Text(Header(time.time(), ""), ident), Text, deadline=20.0)
            say("ACK", ident)
        except Exception as e:  # noqa: BLE001 - reported, counted by the benchmark
            say("NOACK", ident, f"(master's status stream last heard {status.age():.1f} s ago)",
                str(e).replace("\n", " "))

    def latched(ident: str) -> None:
        node.subscribe("map", Text, mode="latest", callback=lambda m: say("LATCHED", ident))

    say("READY")
    for line in sys.stdin:
        w = line.split()
        if not w:
            continue
        if w[0] == "stream":
            threading.Thread(target=stream, args=(w[1], goal), daemon=True).start()
        elif w[0] == "fresh":
            threading.Thread(target=stream, args=(w[1], node.publisher("goal")), daemon=True).start()
        elif w[0] == "stop" and w[1] in streams:
            streams.pop(w[1]).set()
        elif w[0] == "call":
            threading.Thread(target=call, args=(w[1],), daemon=True).start()
        elif w[0] == "latched":
            latched(w[1])
        elif w[0] == "await":
            awaiting.append(w[1])
    node.close()


if __name__ == "__main__":
    {"master": master, "robot": robot, "extra": extra, "agent": agent}[sys.argv[1]]()
