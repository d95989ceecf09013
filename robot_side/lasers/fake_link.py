"""The fake Hokuyo's link: a pty (a USB-serial device such as the URG-04LX) or a TCP server that takes
one client at a time (an Ethernet device such as the UST-10LX). Bytes only; the protocol is the subclass's."""

from __future__ import annotations

import contextlib
import os
import select
import socket
import time
from typing import Any, Self

from robot_side.fake_device import open_raw_pty


class FakeDeviceLink:
    """Base of a fake device: ``on_pty`` / ``on_tcp`` build one, ``_recv`` / ``_send`` move bytes,
    ``_close_link`` frees the pty or sockets; ``_client_gone`` is called when a TCP client hangs up."""

    def __init__(self) -> None:
        self._rx = b""
        self._fd: int | None = None
        self._slave: int | None = None
        self._server: socket.socket | None = None
        self._conn: socket.socket | None = None
        self._link: str | None = None

    @classmethod
    def on_pty(cls, link: str | None = None, **kw) -> tuple[Self, str]:
        """A device on a new pty pair (not started); returns it and the path for the driver."""
        fake = cls(**kw)
        fake._fd, fake._slave, path = open_raw_pty(link)
        fake._link = link or None
        return fake, path

    @classmethod
    def on_tcp(cls, host: str = "127.0.0.1", port: int = 0, **kw) -> tuple[Self, tuple[str, int]]:
        """A device listening on TCP (one client at a time); returns it and (host, port)."""
        fake = cls(**kw)
        fake._server = socket.create_server((host, port))  # SO_REUSEADDR: a new fake can take the port
        return fake, fake._server.getsockname()[:2]

    def _client_gone(self) -> None:
        """A TCP client closed its connection (the device forgets its session here)."""

    def _recv(self, timeout: float) -> bytes:
        if self._server is not None and self._conn is None:
            r, _, _ = select.select([self._server], [], [], timeout)
            if r:
                self._conn, _ = self._server.accept()
                self._rx = b""
            return b""
        fd: Any = self._conn if self._conn is not None else self._fd  # a socket or the pty's fd
        r, _, _ = select.select([fd], [], [], timeout)
        if not r:
            return b""
        try:
            data = self._conn.recv(4096) if self._conn is not None else os.read(self._fd, 4096)
        except OSError:
            data = b""
        if not data and self._conn is not None:  # the client went away: wait for the next one
            self._conn.close()
            self._conn = None
            self._client_gone()
        elif not data:
            time.sleep(timeout)
        return data

    def _send(self, data: bytes) -> None:
        try:
            if self._conn is not None:
                self._conn.sendall(data)
            elif self._server is None:
                os.write(self._fd, data)
        except OSError:
            pass

    def _close_link(self) -> None:
        for s in (self._conn, self._server):
            if s is not None:
                s.close()
        for fd in (self._fd, self._slave):
            if fd is not None:
                with contextlib.suppress(OSError):
                    os.close(fd)
        self._conn = self._server = self._fd = self._slave = None
        if self._link and os.path.islink(self._link):
            os.unlink(self._link)
