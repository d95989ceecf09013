"""Helpers shared by the test packages: a free loopback port and a condition wait (never a fixed sleep)."""

from __future__ import annotations

import contextlib
import os
import shutil
import subprocess
import uuid
from typing import Iterator

import pytest

from common.ports import free_port
from testkit.wait import wait_until

__all__ = ["free_port", "ip", "listening", "two_netns", "wait_until"]


def listening(port: int) -> bool:
    """Whether some process listens on TCP ``port`` of 127.0.0.1 (or any IPv4 address) — read from
    /proc/net/tcp, without connecting. Start a Zenoh peer that connects to a child's port after this:
    a connect that finds no listener is retried after 1, 2, 4 s (Zenoh's backoff), and a loaded machine
    that starts the listening child slower than the connecting one then pays those seconds."""
    want = {f"0100007F:{port:04X}", f"00000000:{port:04X}"}
    with open("/proc/net/tcp") as f:
        return any(w[1] in want and w[3] == "0A" for w in (line.split() for line in list(f)[1:]))


def ip(*args: str, check: bool = True) -> subprocess.CompletedProcess:
    return subprocess.run(["ip", *args], capture_output=True, text=True, check=check, timeout=30)


@contextlib.contextmanager
def two_netns(tag: str, subnet: str) -> Iterator[dict[str, str]]:
    """Two network namespaces joined by a veth pair, ``<subnet>.1`` and ``<subnet>.2`` /24, multicast
    routed: {"a", "b" (namespaces), "va", "vb" (their veth ends)}. Skips without root or iproute2;
    deleted afterwards (deleting a namespace deletes its veth end too)."""
    if os.geteuid() != 0:
        pytest.skip("needs root to create network namespaces (ip netns add)")
    if shutil.which("ip") is None:
        pytest.skip("needs the `ip` tool (iproute2)")
    sfx = uuid.uuid4().hex[:6]
    hosts = {k: f"z{tag}{k}{sfx}" for k in ("a", "b", "va", "vb")}
    a, b, va, vb = hosts["a"], hosts["b"], hosts["va"], hosts["vb"]
    try:
        try:
            ip("netns", "add", a)
            ip("netns", "add", b)
            ip("link", "add", va, "type", "veth", "peer", "name", vb)
            ip("link", "set", va, "netns", a)
            ip("link", "set", vb, "netns", b)
            for ns, dev, addr in ((a, va, f"{subnet}.1/24"), (b, vb, f"{subnet}.2/24")):
                ip("-n", ns, "addr", "add", addr, "dev", dev)
                ip("-n", ns, "link", "set", dev, "up")
                ip("-n", ns, "link", "set", "lo", "up")
                ip("-n", ns, "route", "add", "224.0.0.0/4", "dev", dev)
        except subprocess.CalledProcessError as e:
            pytest.skip(f"cannot create network namespaces here: {e.stderr.strip()}")
        yield hosts
    finally:
        for ns in (a, b):
            ip("netns", "del", ns, check=False)
