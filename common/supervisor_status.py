"""How the supervisor shows its nodes: a status table on a text stream and ``NodeState`` on the bus."""

from __future__ import annotations

import contextlib
import threading
import time
from typing import Any, TextIO

from common.messages import Header, NodeState
from common.node_spec import NodeStatus


def status_table(nodes: dict[str, NodeStatus]) -> str:
    """One row per node: name, state, pid, restart count and detail."""
    w = max(12, *(len(n) for n in nodes))
    rows = [f"{'NODE':<{w}} {'STATE':<10} {'PID':>7} {'RESTARTS':>8}  DETAIL"]
    for n, st in nodes.items():
        rows.append(f"{n:<{w}} {st.state:<10} {st.pid or '-':>7} {st.restarts:>8}  {st.detail}")
    return "\n".join(rows)


class StatusReporter:
    """Publishes changed node states (all of them once a second) on ``agent/<agent>/state`` when given
    a bus node, and prints the table to ``status_out`` when it changed, at most every 0.3 s."""

    def __init__(self, nodes: dict[str, NodeStatus], agent: str, node: Any, status_out: TextIO | None,
                 out_lock: threading.Lock) -> None:
        self.nodes, self.agent, self.status_out, self.out_lock = nodes, agent, status_out, out_lock
        self._pub = node.publisher(f"agent/{agent}/state") if node is not None else None
        self._last_table = ""
        self._table_pending, self._last_print = False, 0.0
        self._last_publish_all = 0.0

    def report(self, dirty: set[str], force: bool = False) -> None:
        """Publish and print what changed; ``dirty`` names the nodes whose state changed."""
        now = time.monotonic()
        if self._pub is not None and (dirty or now - self._last_publish_all > 1.0):
            names = list(self.nodes) if now - self._last_publish_all > 1.0 else sorted(dirty)
            if len(names) == len(self.nodes):
                self._last_publish_all = now
            for n in names:
                st = self.nodes[n]
                with contextlib.suppress(Exception):   # the bus must never take the supervisor down
                    self._pub.publish(NodeState(header=Header(stamp=time.time()), node=n, state=st.state,
                                                pid=st.pid, restarts=st.restarts, detail=st.detail))
        self._table_pending |= bool(dirty)
        if self._table_pending and self.status_out is not None and (force or now - self._last_print >= 0.3):
            self._table_pending, self._last_print = False, now
            table = status_table(self.nodes)
            if table != self._last_table:
                self._last_table = table
                with self.out_lock:
                    print(f"--- zenav {self.agent} ---\n{table}", file=self.status_out, flush=True)
