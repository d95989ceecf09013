"""Shared by the protocol fakes' command lines (P2OS, Hokuyo, S300): run a started-able fake until Ctrl-C."""

from __future__ import annotations

import signal
import threading


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
