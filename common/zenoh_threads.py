"""Threads that call into Zenoh end before the interpreter does.

A blocking Zenoh call (a query, a put on a congested link, a liveliness query) releases the GIL while it
waits in Rust. Python 3.11 ends a daemon thread that asks for the GIL back once the interpreter is
finalizing by calling ``pthread_exit`` on it; that unwinds through the Rust frames of the call, pyo3's
guard catches the unwind, and glibc aborts the whole process ("FATAL: exception not rethrown", exit
-6) — after the program's own work was done and its output printed. A CI run saw it: ``zenav demo``
reached its goal, printed its summary, and died with SIGABRT on the way out.

So every thread that may be inside Zenoh is stopped and joined before its owner returns from ``close``
(common.bus.Node.close joins its route watch, timers, subscription workers and senders), and the retries
of latched queries, which run on timer threads of their own, are cancelled with their session and, for
any still pending, at exit (atexit runs before the interpreter starts finalizing).
"""

from __future__ import annotations

import atexit
import logging
import threading
import time
from collections.abc import Iterable
from typing import Any

log = logging.getLogger("zenav.bus")

# how long a node's close waits for its threads: a blocking call on a closed session returns at once, a
# liveliness query of the route watch within its 1 s timeout, a callback of the node's code when it ends
JOIN_TIMEOUT_S = 5.0

_lock = threading.Lock()
_retries: dict[threading.Timer, Any] = {}  # pending retry timer -> its zenoh session


def join_all(threads: Iterable[threading.Thread | None], timeout: float = JOIN_TIMEOUT_S) -> list[str]:
    """Join ``threads`` (the calling thread and None skipped) within ``timeout`` in all; the names of
    those still alive after it."""
    deadline = time.monotonic() + timeout
    left = []
    me = threading.current_thread()
    for t in threads:
        if t is None or t is me or t.ident is None:  # (ident None: never started)
            continue
        t.join(max(0.0, deadline - time.monotonic()))
        if t.is_alive():
            left.append(t.name)
    return left


def track_retry(timer: threading.Timer, session: Any) -> None:
    """A latched query's retry, to be cancelled with ``session`` (``cancel_retries``) or at exit."""
    with _lock:
        for t in [t for t in _retries if t.finished.is_set() and not t.is_alive()]:
            del _retries[t]
        _retries[timer] = session


def cancel_retries(session: Any | None = None) -> list[threading.Timer]:
    """Cancel the pending retries of ``session`` (None: all); the timers, for the caller to join (one
    that already fired may be inside its query)."""
    with _lock:
        mine = [t for t, s in _retries.items() if session is None or s is session]
        for t in mine:
            t.cancel()
            del _retries[t]
    return mine


@atexit.register
def _cancel_all_at_exit() -> None:
    left = join_all(cancel_retries(None))
    if left:
        log.warning("latched-query retries still running at exit: %s", ", ".join(left))
