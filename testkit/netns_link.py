"""Two network namespaces, a master's and a robot's, joined by the user-space link (``linkem.py``): the rig
of the network-fault tests. ``linked_namespaces`` creates them, starts the link, hands out a ``start``
for processes inside either namespace, and takes everything down again: the processes all at once (each
takes its nodes' grace time), the link last — over a cut link every Zenoh session would wait for its
peers before closing — then the namespaces."""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
import uuid
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from testkit.line_proc import LineProc
from testkit.wait import wait_until

REPO = Path(__file__).resolve().parents[1]


def bus_env(robot: str) -> dict[str, str]:
    """This checkout's environment for processes of robot ``robot``: no inherited ZENAV_ setting, no
    shared memory (namespaces do not share it)."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENAV_")}
    env.update(PYTHONPATH=str(REPO), PYTHONUNBUFFERED="1", ZENAV_ROBOT=robot, ZENAV_SHM="0")
    return env


@dataclass
class LinkedNamespaces:
    master: str  # namespace names
    robot: str
    env: dict[str, str]
    logs: Path
    link: LineProc | None = None
    procs: list[LineProc] = field(default_factory=list)

    def start(self, ns: str, argv: list[str], log: str | None = None) -> LineProc:
        """``argv`` inside namespace ``ns``; stderr to ``logs/log`` when given (else with stdout)."""
        p = LineProc(["ip", "netns", "exec", ns, *argv], self.env, self.logs / log if log else None)
        self.procs.append(p)
        return p


def _ip(*args: str) -> None:
    subprocess.run(["ip", *args], check=True, capture_output=True, timeout=30)


@contextlib.contextmanager
def linked_namespaces(tag: str, subnet: str, env: dict[str, str], logs: Path) -> Iterator[LinkedNamespaces]:
    """Namespaces ``z<tag>m…`` / ``z<tag>r…`` with addresses ``<subnet>.1`` / ``<subnet>.2`` (/24)."""
    sfx = uuid.uuid4().hex[:6]
    ns = LinkedNamespaces(f"z{tag}m{sfx}", f"z{tag}r{sfx}", env, logs)
    _ip("netns", "add", ns.master)
    _ip("netns", "add", ns.robot)
    try:
        ns.link = LineProc([sys.executable, str(REPO / "testkit/linkem.py"), ns.master, f"{subnet}.1/24",
                            ns.robot, f"{subnet}.2/24"], env)
        link = ns.link
        wait_until(lambda: link.lines, 30, "the link")
        yield ns
    finally:
        for p in ns.procs:
            p.interrupt()
        for p in reversed(ns.procs):
            p.stop()
        if ns.link is not None:
            ns.link.stop()
        for name in (ns.master, ns.robot):
            subprocess.run(["ip", "netns", "del", name], capture_output=True)
