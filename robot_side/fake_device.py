"""Shared by the protocol fakes (P2OS, Hokuyo, S300): their pty, and running one from a command line until Ctrl-C."""

from __future__ import annotations

import os
import signal
import threading
import tty


def serve_until_signal(fake) -> int:
    """``fake.start()``, wait for SIGINT / SIGTERM, then ``fake.close()``; the exit status (0)."""
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    fake.start()
    try:
        while not stop.wait(0.5):
            pass
    finally:
        fake.close()
    return 0


def open_raw_pty(link: str | None = None) -> tuple[int, int, str]:
    """A new pty pair, binary-clean (raw: no echo, no CR/LF mapping) before a driver opens it:
    (master fd, slave fd, the slave's path). ``link``: also a symlink to it at that path (replacing one
    there). Keep the slave fd open: the master reads EIO once every slave fd is closed."""
    master, slave = os.openpty()
    tty.setraw(slave)
    path = os.ttyname(slave)
    if link:
        if os.path.lexists(link):
            os.unlink(link)
        os.symlink(path, link)
    return master, slave, path
