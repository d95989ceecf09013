"""The bus side of ``NodeSpec.wait_for``: one subscription per awaited topic, dropped when unused."""

from __future__ import annotations

import contextlib
import threading
from typing import Any

from common.node_spec import WAITING, NodeStatus


class TopicWatcher:
    """Marks a topic as seen on every node that waits for it, and wakes the supervisor."""

    def __init__(self, node: Any, nodes: dict[str, NodeStatus], wake: threading.Event) -> None:
        self.node, self.nodes, self.wake = node, nodes, wake
        self._subs: dict[str, Any] = {}

    def watch(self, topic: str) -> None:
        if topic in self._subs or self.node is None:
            return
        key = self.node.key(topic)

        def seen(*_a) -> None:
            for st in self.nodes.values():
                if topic in st.spec.wait_for:
                    st.seen.add(topic)
            self.wake.set()

        sess = self.node.session
        self._subs[topic] = sess.declare_subscriber(key, seen)
        sess.get(key, lambda r: seen() if r.ok is not None else None)   # latched publishers

    def unwatch_unused(self) -> None:
        """Drop the subscriptions no WAITING node needs any more."""
        wanted = {t for st in self.nodes.values() if st.state == WAITING for t in st.spec.wait_for}
        self._drop([t for t in self._subs if t not in wanted])

    def close(self) -> None:
        self._drop(list(self._subs))

    def _drop(self, topics: list[str]) -> None:
        for t in topics:
            with contextlib.suppress(Exception):
                self._subs.pop(t).undeclare()
