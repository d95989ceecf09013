"""A process must not abort on its way out because a thread of one of its nodes is inside Zenoh
(common/zenoh_threads.py): a CI run saw ``zenav demo`` reach its goal, print its summary and die with
SIGABRT ("FATAL: exception not rethrown"). The first test ends a program while a node's thread waits in a
service call to a queryable that never answers (the node's close must release and end it); the second
checks the invariant behind it: no thread of a node outlives ``Node.close``."""

from __future__ import annotations

import subprocess
import sys
import uuid

import pytest
from bushelp import REPO, free_port

from deploy.stack.process_group import checkout_env

PROGRAM = r"""
import sys, threading
from common.bus import Node
from common.messages import Text
from common.zenoh_config import BusConfig

robot, port, where = sys.argv[1:]
node = Node("exiting", config=BusConfig(robot=robot, multicast=False, listen=(f"tcp/127.0.0.1:{port}",)))
held = []  # the queries, never answered
node.queryables.declare(f"zenav/{robot}/srv/silent", held.append, complete=True)
inside = threading.Event()

def blocked(*_):
    inside.set()
    try:
        node.call("silent", Text(data="?"), timeout=60.0)
    except Exception:
        pass

if where == "subscription":
    node.subscribe("kick", Text, callback=blocked)
    other = Node("kicker", config=BusConfig(robot=robot, multicast=False, connect=(f"tcp/127.0.0.1:{port}",)))
    pub = other.publisher("kick")
    while not inside.wait(0.05):
        pub.publish(Text(data="go"))
    other.close()
elif where == "timer":
    node.timer(0.01, blocked)
    inside.wait(120)
node.close()
print("closed", flush=True)
"""


@pytest.mark.parametrize("where", ["subscription", "timer"])
def test_a_node_closed_while_its_thread_waits_in_zenoh_exits_cleanly(where):
    robot = f"exit{uuid.uuid4().hex[:8]}"
    proc = subprocess.run([sys.executable, "-c", PROGRAM, robot, str(free_port()), where], cwd=REPO,
                          env=checkout_env(drop_zenav=True), capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, (proc.returncode, proc.stdout, proc.stderr[-2000:])
    assert "closed" in proc.stdout
    assert "exception not rethrown" not in proc.stderr


def test_no_thread_of_a_node_outlives_its_close(node_pair):
    """What makes the clean exit above certain rather than likely: when ``Node.close`` returns, its route
    watch, timers, subscription workers, background senders and latched-query retries have ended, so
    none can be inside Zenoh when the interpreter finalizes (a call on the closed session would return at
    once, but a thread descheduled in it on a loaded machine is still there when the main thread ends)."""
    import threading

    from bushelp import wait_for

    from common.messages import Text
    from common.tf import StaticTFBroadcaster

    a, b = node_pair("closing"), node_pair("feeding")
    got = threading.Event()
    a.subscribe("kick", Text, callback=lambda _m: got.set())
    a.subscribe("never_published", Text, callback=lambda _m: None)
    a.subscribe("latched_elsewhere", Text)  # b's latched publisher: a's retries of its query
    a.publisher("state", background=True).publish(Text(data="s"))
    a.timer(0.01, lambda: None)
    StaticTFBroadcaster(a, republish_s=0.05)
    b.publisher("latched_elsewhere", latched=True)  # never publishes: a keeps asking
    pub = b.publisher("kick")
    wait_for(lambda: pub.publish(Text(data="go")) or got.is_set(), 30.0, "a's subscription to be fed")
    mine = [t for t in threading.enumerate() if t is not threading.main_thread()
            and any(s in t.name for s in ("closing", "kick", "never_published", "state", "tf_static"))]
    assert len(mine) >= 5, [t.name for t in mine]
    a.close()
    alive = [t.name for t in mine if t.is_alive()]
    assert not alive, f"still running after close: {alive}"
