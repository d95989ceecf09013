"""What a launch is made of: ``NodeSpec`` (one node of a launch file), ``NodeStatus`` (its live state
under the supervisor), the state names, and ``validate_launch`` (unique names, known ``after``
targets, no dependency cycles). Plain data; ``common.supervisor`` runs them."""

from __future__ import annotations

import subprocess
import sys
import threading
from collections import deque
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from common.fork_server import ForkedProc

WAITING, STARTING, RUNNING, RESTARTING = "WAITING", "STARTING", "RUNNING", "RESTARTING"
EXITED, FAILED, STOPPING, STOPPED = "EXITED", "FAILED", "STOPPING", "STOPPED"
TERMINAL = (EXITED, FAILED, STOPPED)


@dataclass(frozen=True)
class NodeSpec:
    name: str
    module: str = ""                    # python -m target
    cmd: tuple[str, ...] = ()           # or an explicit argv
    args: tuple[str, ...] = ()          # extra arguments appended to the command line
    config: str = ""                    # --config FILE (module nodes)
    section: str = ""                   # --section KEY
    env: dict[str, str] = field(default_factory=dict)
    respawn: bool = False
    respawn_delay: float = 0.2
    required: bool = False
    wait_for: tuple[str, ...] = ()      # topics that must carry a message before the first start
    wait_timeout: float = 30.0
    after: tuple[str, ...] = ()         # node names that must be RUNNING first
    stop_first: bool = False

    def __post_init__(self):
        if not self.name or any(c in self.name for c in "/*. "):
            raise ValueError(f"bad node name {self.name!r}")
        if bool(self.module) == bool(self.cmd):
            raise ValueError(f"node {self.name!r}: give exactly one of module / cmd")

    def argv(self) -> list[str]:
        if self.cmd:
            return [*self.cmd, *self.args]
        out = [sys.executable, "-m", self.module, "--name", self.name]
        if self.config:
            out += ["--config", self.config]
        if self.section:
            out += ["--section", self.section]
        return out + list(self.args)


@dataclass
class NodeStatus:
    spec: NodeSpec
    state: str = WAITING
    pid: int = 0
    restarts: int = 0
    detail: str = ""
    exit_code: int | None = None
    pids: list[int] = field(default_factory=list)          # every pid ever started
    deaths: deque = field(default_factory=lambda: deque(maxlen=64))
    proc: subprocess.Popen | ForkedProc | None = None
    start_at: float = 0.0                                   # RESTARTING: when to spawn
    seen: set = field(default_factory=set)                  # wait_for topics seen
    wait_since: float = 0.0
    tail: deque = field(default_factory=lambda: deque(maxlen=20))      # last output lines
    pump: threading.Thread | None = None                    # reads the output of the current process


def validate_launch(specs: list[NodeSpec]) -> None:
    """Unique names, known ``after`` targets, no cycles. Raises ValueError."""
    names = [s.name for s in specs]
    dup = {n for n in names if names.count(n) > 1}
    if dup:
        raise ValueError(f"duplicate node names: {sorted(dup)}")
    for s in specs:
        for a in s.after:
            if a not in names:
                raise ValueError(f"node {s.name!r}: after: unknown node {a!r}")
    by_name, done, visiting = {s.name: s for s in specs}, set(), set()

    def visit(n: str, path: list[str]) -> None:
        if n in done:
            return
        if n in visiting:
            raise ValueError(f"dependency cycle: {' -> '.join(path + [n])}")
        visiting.add(n)
        for a in by_name[n].after:
            visit(a, path + [n])
        visiting.discard(n)
        done.add(n)

    for s in specs:
        visit(s.name, [])
