"""Zenoh's TCP links must not block a thread when they close: every session opens with ``open_session``.

Zenoh (1.10) sets ``SO_LINGER`` to 10 s on each TCP link's socket (``TCP_LINGER_TIMEOUT``, fixed when the
library is built; no configuration key changes it). With a linger set, Linux's ``close(2)`` waits until
the peer has acknowledged everything sent, the FIN included, or until the timeout. When a link to the
other machine is cut, the lease expires (1 s here), Zenoh tears the transport down, and the socket's last
reference is dropped on one of the two worker threads that read every link *and route every message* of
the process. That ``close`` then sleeps until the link heals, up to 10 s. Seen as: a robot agent routing
its nodes' topics to the robot's own subscribers went silent from about 1.9 s into a 3 s partition until
the heal (tests/reliability/test_cut_link_routes.py, 3 suite runs in about 25; with one routing thread,
``ZENOH_RUNTIME='(rx:(worker_threads:1))'``, 4 runs of 4). The same links without a linger close at once
and the kernel still delivers what was queued if the peer comes back (an ordinary close).

So a guard thread, one per process, turns the linger off on the process's sockets that have a blocking one: every
``SCAN_S`` it lists ``/proc/self/fd`` and asks each descriptor for its linger (a few dozen ``getsockopt``
calls, tens of microseconds). A link older than ``SCAN_S`` is covered; one cut sooner after it opened can
still linger. Zenoh's own fix is pending upstream (eclipse-zenoh/zenoh#2350, "should not use deprecated
set_linger"); when a release drops the linger, the guard finds nothing to do. Linux only (elsewhere it
does nothing).
"""

from __future__ import annotations

import ctypes
import logging
import os
import socket
import threading
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import zenoh

log = logging.getLogger("zenav.bus")

SCAN_S = 0.25
_FD_DIR = "/proc/self/fd"


class _Linger(ctypes.Structure):
    _fields_ = [("l_onoff", ctypes.c_int), ("l_linger", ctypes.c_int)]


_libc = ctypes.CDLL(None, use_errno=True) if os.path.isdir(_FD_DIR) else None


def _linger(fd: int) -> _Linger | None:
    """The socket's linger setting, or None when ``fd`` is not a socket (any more)."""
    assert _libc is not None
    value, size = _Linger(), ctypes.c_uint32(ctypes.sizeof(_Linger))
    if _libc.getsockopt(fd, socket.SOL_SOCKET, socket.SO_LINGER, ctypes.byref(value), ctypes.byref(size)):
        return None
    return value


def _fds() -> list[int]:
    return [int(name) for name in os.listdir(_FD_DIR)]


def lingering_sockets() -> list[int]:
    """Descriptors of this process's sockets with a linger of some seconds (a close of these can block; a
    linger of 0 s, an abortive close, never blocks and is left as it is)."""
    if _libc is None:
        return []
    return [fd for fd in _fds() if (lg := _linger(fd)) is not None and lg.l_onoff and lg.l_linger > 0]


class LingerGuard:
    """Turns off the linger of this process's sockets. Every descriptor is looked at on every scan: a
    socket still connecting gets its linger from Zenoh only once connected (seconds later toward an
    unreachable machine), so one seen without a linger may have one at the next scan."""

    def __init__(self) -> None:
        self.cleared = 0  # sockets whose linger was turned off

    def scan(self) -> int:
        """One look at every descriptor; the number of lingers turned off. A descriptor closed, or used
        again, between the listing and the look is harmless: a closed one is no socket (skipped), and
        turning a linger off never makes a close block."""
        if _libc is None:
            return 0
        n = 0
        off = _Linger(0, 0)
        for fd in lingering_sockets():
            if _libc.setsockopt(fd, socket.SOL_SOCKET, socket.SO_LINGER, ctypes.byref(off), ctypes.sizeof(off)) == 0:
                n += 1
        self.cleared += n
        return n


_guard: LingerGuard | None = None
_lock = threading.Lock()


def start_linger_guard() -> LingerGuard:
    """The process's guard, its thread started on the first call."""
    global _guard
    with _lock:
        if _guard is None:
            _guard = LingerGuard()
            if _libc is not None:
                threading.Thread(target=_run, args=(_guard,), name="tcp-linger-guard", daemon=True).start()
        return _guard


def _forget_in_child() -> None:
    """A fork has no guard thread (threads are not copied): its first session starts its own."""
    global _guard, _lock
    _guard, _lock = None, threading.Lock()


os.register_at_fork(after_in_child=_forget_in_child)


def _run(guard: LingerGuard) -> None:
    stop = threading.Event()
    while not stop.wait(SCAN_S):
        try:
            guard.scan()
        except Exception:  # noqa: BLE001 - a guard must never end the process; say it once and stop
            log.exception("tcp linger guard stopped")
            return


def open_session(conf: zenoh.Config) -> zenoh.Session:
    """``zenoh.open(conf)`` with the process's linger guard running (see the module's docstring)."""
    import zenoh  # noqa: F811 - at call time: importing this module must not load Zenoh

    start_linger_guard()
    return zenoh.open(conf)
