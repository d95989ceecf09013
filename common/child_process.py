"""Child processes of the supervisor: their bus environment, death with the parent, process groups."""

from __future__ import annotations

import contextlib
import ctypes
import os
import signal
import sys

from common.zenoh_config import BusConfig


def child_bus_env(cfg: BusConfig) -> dict[str, str]:
    """Bus env for children: same network, but listening on ephemeral ports (the agent's own listen
    ports would clash) and connecting to the agent's listen endpoints as well."""
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
    return BusConfig(**{**cfg.__dict__, "connect": tuple(dict.fromkeys(connect)),
                        "listen": tuple(dict.fromkeys(listen))}).to_env()


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
