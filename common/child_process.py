"""Child processes of the supervisor: their bus environment, death with the parent, process groups."""

from __future__ import annotations

import contextlib
import ctypes
import os
import signal
import sys
import tempfile
from dataclasses import replace

from common.zenoh_config import BusConfig


def agent_socket(agent: str) -> str:
    """A Unix-socket endpoint for an agent's nodes to reach it (``BusConfig.children == "agent"``): in a
    directory only this user can enter, named by agent and process id so that agents never share one."""
    base = os.environ.get("XDG_RUNTIME_DIR") or tempfile.gettempdir()
    folder = os.path.join(base, f"zenav-{os.getuid()}")
    os.makedirs(folder, mode=0o700, exist_ok=True)
    os.chmod(folder, 0o700)
    name = "".join(c if c.isalnum() or c in "-_" else "_" for c in agent)[:32]
    return f"unixsock-stream/{os.path.join(folder, f'{name}-{os.getpid()}.sock')}"


def child_bus_env(cfg: BusConfig, agent_endpoint: str = "") -> dict[str, str]:
    """Bus env for an agent's children. With ``agent_endpoint`` (the agent listens there, see
    ``agent_socket``) each child is a client of its agent alone. Without it (``children: mesh``, or an
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
