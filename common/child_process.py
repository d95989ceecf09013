"""Child processes of the supervisor: their bus environment, death with the parent, process groups."""

from __future__ import annotations

import contextlib
import ctypes
import os
import signal
import sys
from dataclasses import replace

from common.ports import free_port
from common.zenoh_config import BusConfig


def pick_agent_endpoint() -> str:
    """Where an agent's nodes reach it (``BusConfig.children == "agent"``): a TCP port on 127.0.0.1. The
    agent advertises it to other peers with its other locators; loopback is private to each machine and
    each network namespace, so a peer elsewhere cannot reach the agent through it (a Unix socket's path,
    the first choice, was dialled from other network namespaces of one machine through the shared file
    system, past a cut link). A port taken between the pick and the agent's bind: the agent picks
    another (``common.launch``)."""
    return f"tcp/127.0.0.1:{free_port()}"


def child_bus_env(cfg: BusConfig, agent_endpoint: str = "") -> dict[str, str]:
    """Bus env for an agent's children. With ``agent_endpoint`` (the agent listens there, see
    ``pick_agent_endpoint``) each child is a client of its agent alone. Without it (``children: mesh``, or an
    agent that is itself a client of a router) the children join as the agent does, listening on
    ephemeral ports (the agent's own listen ports would clash) and connecting to the agent's listen
    endpoints as well."""
    if agent_endpoint and cfg.mode != "client":
        return replace(cfg, via_agent=agent_endpoint, local_listen=()).to_env()
    def host_port(ep: str) -> tuple[str, str]:
        proto_addr = ep.split("#", 1)[0]
        head, _, port = proto_addr.rpartition(":")
        return head, port

    connect, listen = list(cfg.connect), []
    for ep in cfg.listen:
        head, port = host_port(ep)
        listen.append(f"{head}:0")
        if port not in ("", "0"):
            connect.append(ep.split("#", 1)[0].replace("0.0.0.0", "127.0.0.1").replace("[::]", "[::1]"))
    return replace(cfg, connect=tuple(dict.fromkeys(connect)), listen=tuple(dict.fromkeys(listen)),
                   local_listen=()).to_env()


try:
    _LIBC = ctypes.CDLL(None, use_errno=True) if sys.platform.startswith("linux") else None
except OSError:  # pragma: no cover
    _LIBC = None
_PR_SET_PDEATHSIG = 1


def make_preexec(parent: int):
    def preexec() -> None:   # runs in the child between fork and exec: no locks, no imports
        if _LIBC is not None:
            _LIBC.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
            if os.getppid() != parent:   # parent already gone before prctl took effect
                os._exit(1)
    return preexec


def killpg(pid: int, sig: int) -> None:
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(pid, sig)
