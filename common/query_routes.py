"""Queries are watched too: a queryable that a querier cannot reach is declared again by its owner, when asked.

A service call or a latched fetch is a Zenoh query; it reaches only the queryables whose declarations
reached the querier. After a healed partition that declaration can be missing on one side for minutes
while puts flow both ways (bench/reconnect.py under load: 4 of 200 cycles, the goal's query "reached no
node" for 20 s while its status stream was heard 0.1 s before; Zenoh issue #2806 has this shape). The
querier cannot re-send someone else's declaration, but puts still get through: it asks on
``zenav/<robot>/_bus/redeclare`` (the key it found no route to), and the node owning a queryable on that
key undeclares and declares it again, so every peer learns it anew. At most once per ``MIN_INTERVAL_S``
per key on both sides: a query to a node that is really gone costs one small put every few seconds.
"""

from __future__ import annotations

import contextlib
import logging
import threading
import time
from typing import Callable

import zenoh

from common.codec import DecodeError, decode, encode
from common.messages import Header, Text

log = logging.getLogger("zenav.bus")

MIN_INTERVAL_S = 2.0


def redeclare_key(robot: str) -> str:
    return f"zenav/{robot}/_bus/redeclare"


_asked: dict[str, float] = {}  # key -> monotonic time this process last asked
_asked_lock = threading.Lock()


def ask_redeclare(session: zenoh.Session, key: str, who: str) -> bool:
    """A query on ``key`` (``zenav/<robot>/...``) reached no queryable: ask its owner to declare it again.
    Returns whether a request was sent (not when this process asked for ``key`` less than
    ``MIN_INTERVAL_S`` ago)."""
    now = time.monotonic()
    with _asked_lock:
        if now - _asked.get(key, -1e9) < MIN_INTERVAL_S:
            return False
        _asked[key] = now
    robot = key.split("/")[1]
    with contextlib.suppress(zenoh.ZError):  # the session is closing
        session.put(redeclare_key(robot), encode(Text(Header(), key)), attachment=who.encode())
    return True


class _Declared:
    """One queryable of a node; ``redeclare()`` replaces its Zenoh declaration."""

    def __init__(self, owner: Queryables, key: str, callback: Callable[[zenoh.Query], None], complete: bool):
        self.owner, self.key, self._callback, self._complete = owner, key, callback, complete
        self.handle = owner.session.declare_queryable(key, callback, complete=complete)
        self.last = -1e9  # monotonic time of the last redeclaration

    def redeclare(self) -> None:
        with contextlib.suppress(zenoh.ZError):
            self.handle.undeclare()
        self.handle = self.owner.session.declare_queryable(self.key, self._callback, complete=self._complete)

    def undeclare(self) -> None:
        self.owner.remove(self)
        with contextlib.suppress(zenoh.ZError):
            self.handle.undeclare()


class Queryables:
    """A node's queryables (services, latched publishers), each declared again when a querier asks."""

    def __init__(self, session: zenoh.Session, robot: str, node_name: str) -> None:
        self.session, self.node_name = session, node_name
        self.redeclared = 0  # declarations made again on request (tests, stats)
        self.malformed = 0  # requests that did not decode (dropped)
        self._lock = threading.Lock()
        self._all: list[_Declared] = []
        self._sub = session.declare_subscriber(redeclare_key(robot), self._on_request)

    def declare(self, key: str, callback: Callable[[zenoh.Query], None], complete: bool) -> _Declared:
        d = _Declared(self, key, callback, complete)
        with self._lock:
            self._all.append(d)
        return d

    def remove(self, d: _Declared) -> None:
        with self._lock, contextlib.suppress(ValueError):
            self._all.remove(d)

    def _on_request(self, sample: zenoh.Sample) -> None:
        try:
            key = decode(sample.payload.to_bytes(), Text).data
        except DecodeError:
            self.malformed += 1
            return
        who = sample.attachment.to_bytes().decode(errors="replace") if sample.attachment is not None else "?"
        now = time.monotonic()
        with self._lock:
            due = [d for d in self._all if d.key == key and now - d.last >= MIN_INTERVAL_S]
            for d in due:
                d.last = now
        for d in due:
            try:
                d.redeclare()
            except zenoh.ZError:  # the session is closing
                return
            self.redeclared += 1
            log.warning("[%s] queryable '%s' declared again: %s's query found no route to it", self.node_name,
                        key, who)

    def close(self) -> None:
        with contextlib.suppress(zenoh.ZError):
            self._sub.undeclare()
        with self._lock:
            items, self._all = self._all, []
        for d in items:
            with contextlib.suppress(zenoh.ZError):
                d.handle.undeclare()
