"""Loopback TCP ports for private Zenoh links (test buses, an agent's link to its own nodes)."""

from __future__ import annotations

import os
import random
import socket

_HANDED_OUT: set[int] = set()
LOW, HIGH = 20000, 32768  # below Linux's ephemeral range (32768-60999)


def port_range() -> tuple[int, int]:
    """[lo, hi) to pick from: ``ZENAV_PORT_RANGE=LO-HI`` narrows it (the test suite gives each parallel worker
    its own, so two workers never pick the same port; tests/conftest.py)."""
    lo, _, hi = os.environ.get("ZENAV_PORT_RANGE", "").partition("-")
    try:
        lo_i, hi_i = int(lo), int(hi)
    except ValueError:
        return LOW, HIGH
    return (lo_i, hi_i) if 1024 <= lo_i < hi_i <= 65536 else (LOW, HIGH)


def free_port() -> int:
    """A TCP port on 127.0.0.1 that is free right now.

    Picked at random below Linux's ephemeral range (32768-60999): a port the kernel hands out for
    ``bind(0)`` — every Zenoh peer's own listener, every outgoing connection — could be taken by another
    process between this check and our bind (seen in CI: "Address already in use"); these cannot. Another
    process picking the same port at the same moment still can (port_range keeps the suite's parallel workers
    apart: ci105 lost a test to the other worker's pick): a caller that binds it later retries on "Address
    already in use" (``is_address_in_use``)."""
    lo, hi = port_range()
    for _ in range(200):
        port = random.randrange(lo, hi)
        if port in _HANDED_OUT:
            continue
        with socket.socket() as s:
            try:
                s.bind(("127.0.0.1", port))
            except OSError:
                continue
        _HANDED_OUT.add(port)
        return port
    with socket.socket() as s:  # the low range is crowded: fall back to the kernel's choice
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def is_address_in_use(error: BaseException) -> bool:
    """Whether opening a Zenoh session failed because one of its listen ports was taken meanwhile."""
    return "Address already in use" in str(error)
