"""A process group's peers find each other again after one link between two of them is cut.

The benches and `zenav demo` run their processes as peers on a private loopback network
(deploy/stack/process_group.py). A link Zenoh found by gossip is not dialled again once it closes while
the two peers' other links stand, so `zenav explore` once heard no clock from the simulator for six
minutes. In the group every link is one a process was told to open, and Zenoh dials those again.

Here `zenav play` publishes a clock and `zenav topic hz clock` counts it, both spawned by a ProcessGroup.
The TCP connection between the two is reset (``ss -K``, as root; a socket reset, as when a lease expires
under load), and the counter must hear the clock again, over a new connection between the same two
processes.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

from common.bus import Node
from common.ports import free_port
from deploy.stack.process_group import ProcessGroup
from testkit.wait import wait_until

LOG = Path(__file__).resolve().parents[3] / "shared" / "datasets" / "slam" / "aces.recon.clf"

pytestmark = pytest.mark.skipif(os.geteuid() != 0 or shutil.which("ss") is None,
                                reason="resetting a socket (ss -K) needs root and iproute2")


def _links(a: int, b: int) -> set[tuple[str, str]]:
    """The established TCP connections of process ``a`` whose other end is a socket of process ``b``, as
    (a's address, b's address)."""
    rows = [line.split() for line in subprocess.run(["ss", "-tnpH"], capture_output=True, text=True,
                                                     check=True).stdout.splitlines()]
    of_b = {r[3] for r in rows if f"pid={b}," in r[-1]}
    return {(r[3], r[4]) for r in rows if f"pid={a}," in r[-1] and r[4] in of_b}


def _flowing(log: Path, offset: int, n: int) -> bool:
    """Whether the last ``n`` reports of `zenav topic hz` after ``offset`` in its log are all rates (none
    "no new messages")."""
    lines = [line for line in log.read_text()[offset:].splitlines()
             if line.startswith(("average rate", "no new messages"))]
    return len(lines) >= n and all(x.startswith("average") for x in lines[-n:])


def test_a_reset_link_between_two_spawned_peers_comes_back(robot_name, tmp_path):
    if not LOG.exists():
        pytest.skip(f"dataset missing: {LOG}")
    group = ProcessGroup(robot_name, f"tcp/127.0.0.1:{free_port()}", tmp_path)
    hub = Node("links_test", config=group.hub_config())
    try:
        play = group.spawn("play", ["play", str(LOG), "--loop", "--topics", "scan", "-q"])
        hz = group.spawn("hz", ["topic", "hz", "clock", "--window", "20"])
        hz_log = tmp_path / "hz.log"
        wait_until(lambda: _flowing(hz_log, 0, 2), 90, "the counter hearing the clock", period=0.2)
        old = wait_until(lambda: _links(hz.pid, play.pid), 30, "a link between the two processes", period=0.2)
        offset = len(hz_log.read_text())
        for _local, remote in old:
            host, port = remote.rsplit(":", 1)
            subprocess.run(["ss", "-K", "dst", host, "dport", "=", port], capture_output=True)
        if _links(hz.pid, play.pid) & old:
            pytest.skip("this kernel cannot reset a socket (ss -K: CONFIG_INET_DIAG_DESTROY)")
        # a new connection between the same two processes, and the clock heard over it
        wait_until(lambda: _links(hz.pid, play.pid) - old, 30, "the link opened again", period=0.2)
        wait_until(lambda: _flowing(hz_log, offset, 3), 30, "the counter hearing the clock again after the reset",
                   period=0.2)
        group.check_alive()
    finally:
        group.stop()
        hub.close()
