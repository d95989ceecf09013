"""A cut link to the master must not silence the robot's own routes.

Robot and master in two network namespaces joined by the user-space link (testkit/linkem.py), the robot
side run by a real robot agent (``zenav robot``: its nodes are clients of the agent, which routes for
them). A node of the robot publishes a 50 Hz stream, a laser scan (a Hokuyo UTM-30LX's, 40 Hz) and, like
the collision monitor, a latched state at 10 Hz; a peer on the master's side subscribes to all three, and
a peer on the robot's side to the stream and the state (a robot-side consumer, as the base is of the
monitor's commands).

Measured: while the link is cut, the robot-side peer keeps receiving the stream. Before, the latched state
was put with Zenoh's *block* congestion control: the agent, routing it toward the master behind the cut
link, held that link's send lock for up to ``wait_before_close`` (5 s) per message while the lease could
not close the link, and every route through the agent stopped: here the robot-side peer got nothing for
2.5 s of the 3 s cut in 4 runs of 4 (0.02 s since), and link fault (c) saw the monitor's zero commands
and the simulator's ground truth vanish this way in 3 of 6 suite runs. After the heal the master's side
receives both again.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
import uuid
from pathlib import Path

import pytest

from testkit.line_proc import LineProc
from tests.support import wait_until

pytestmark = [pytest.mark.netns]

REPO = Path(__file__).resolve().parents[2]
HERE = Path(__file__).parent
CUT_S = 3.0
MAX_GAP_S = 1.0  # a 50 Hz stream on a busy 2-core machine; the stall this guards against lasts the cut


def _ip(*args: str) -> None:
    subprocess.run(["ip", *args], check=True, capture_output=True, timeout=30)


def _gaps(times: list[float], since: float, until: float) -> float:
    """The longest interval without a message within [since, until]."""
    inside = [since] + [t for t in times if since < t < until] + [until]
    return max(b - a for a, b in zip(inside, inside[1:]))


def test_a_cut_link_to_the_master_does_not_stop_robot_side_routes(tmp_path):
    if os.geteuid() != 0:
        pytest.skip("needs root for network namespaces")
    sfx = uuid.uuid4().hex[:6]
    ns_m, ns_r = f"zcrm{sfx}", f"zcrr{sfx}"
    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENAV_")}
    env.update(PYTHONPATH=str(REPO), PYTHONUNBUFFERED="1", ZENAV_ROBOT=f"cr{sfx}", ZENAV_SHM="0")
    launch = tmp_path / "robot.yaml"
    node = f"[{sys.executable}, {HERE / 'cut_peer.py'}, robot_node]"
    launch.write_text(f"platform:\n  cut_robot_node:\n    cmd: {node}\n")
    _ip("netns", "add", ns_m)
    _ip("netns", "add", ns_r)
    procs: list[LineProc] = []
    try:
        link = LineProc([sys.executable, str(REPO / "testkit/linkem.py"), ns_m, "10.79.0.1/24", ns_r,
                         "10.79.0.2/24"], env)
        procs.append(link)
        wait_until(lambda: link.lines, 30, "the link")

        def start(ns: str, argv: list[str], log: str | None = None) -> LineProc:
            p = LineProc(["ip", "netns", "exec", ns, *argv], env, tmp_path / log if log else None)
            procs.append(p)
            return p
        start(ns_r, [sys.executable, "-m", "deploy.cli", "robot", "--config", str(launch)], "robot.log")
        robot_peer = start(ns_r, [sys.executable, str(HERE / "cut_peer.py")])
        master_peer = start(ns_m, [sys.executable, str(HERE / "cut_peer.py"), "master"])
        for who, p in (("robot side", robot_peer), ("master side", master_peer)):
            wait_until(lambda p=p: p.events("GT") and p.events("STATE"), 120, f"both topics on the {who}")
        assert link.command("partition", 10) is not None
        t_cut = time.time()
        try:
            wait_until(lambda: time.time() > t_cut + CUT_S, 10 + CUT_S, "the cut")
        finally:
            assert link.command("heal", 10) is not None
        t_heal = time.time()
        gap = _gaps([float(w[0]) for w in robot_peer.events("GT", t_cut - 1.0)], t_cut, t_heal)
        print(f"robot side: longest gap in the 50 Hz stream during a {t_heal - t_cut:.1f} s cut: {gap:.2f} s")
        assert gap < MAX_GAP_S, f"robot-side routes stalled for {gap:.2f} s of a {t_heal - t_cut:.1f} s cut"
        wait_until(lambda: master_peer.events("GT", t_heal) and master_peer.events("STATE", t_heal), 60,
                   "both topics on the master's side after the heal")
    finally:
        for p in procs[1:]:
            p.interrupt()
        for p in reversed(procs):
            p.stop()
        for ns in (ns_m, ns_r):
            subprocess.run(["ip", "netns", "del", ns], capture_output=True)
