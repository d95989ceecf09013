"""A child process that speaks in lines: the link emulator, the probes and peers of the network-fault tests
and of bench/reconnect.py. Each stdout line is kept split into words (wall time, kind, values); stdin
takes commands."""

from __future__ import annotations

import contextlib
import os
import subprocess
import threading
import time
from pathlib import Path


class LineProc:
    """``log``: stderr goes there (else it joins stdout). ``stop()`` ends stdin — our probes, peers and the
    link stop at the end of their input — and sends SIGINT to a ``zenav`` agent (``deploy.cli``)."""

    def __init__(self, argv: list[str], env: dict, log: Path | None = None) -> None:
        self.lines: list[list[str]] = []
        self.interrupted = False
        self.log = open(log, "w") if log else None  # noqa: SIM115 - closed in stop()
        self.p = subprocess.Popen(argv, env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                  stderr=self.log or subprocess.STDOUT, text=True, start_new_session=True)
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        for line in self.p.stdout:
            self.lines.append(line.split())

    def send(self, text: str) -> None:
        self.p.stdin.write(text + "\n")
        self.p.stdin.flush()

    def command(self, text: str, timeout: float) -> list[str] | None:
        """Send ``text`` and wait for the next line (its answer); None if none came within ``timeout`` s."""
        n = len(self.lines)
        self.send(text)
        end = time.monotonic() + timeout
        while len(self.lines) <= n:
            if time.monotonic() >= end:
                return None
            time.sleep(0.01)
        return self.lines[n]

    def events(self, kind: str, since: float = 0.0) -> list[list[str]]:
        """Lines of ``kind`` stamped at or after ``since`` (wall time)."""
        return [w for w in list(self.lines) if len(w) > 1 and w[1] == kind and float(w[0]) >= since]

    def first(self, kind: str, value: str | None = None, prefix: str | None = None) -> list[str] | None:
        """The first line of ``kind`` whose first value is ``value`` / starts with ``prefix``."""
        for w in list(self.lines):
            if len(w) > 1 and w[1] == kind and (value is None or w[2] == value) \
                    and (prefix is None or w[2].startswith(prefix)):
                return w
        return None

    def interrupt(self) -> None:
        """End of input stops a probe, a peer or the link (they read commands); an agent gets SIGINT."""
        if self.interrupted:
            return
        self.interrupted = True
        with contextlib.suppress(OSError):
            self.p.stdin.close()
        if self.p.poll() is None and "deploy.cli" in self.p.args:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(self.p.pid, 2)

    def stop(self) -> None:
        if self.p.poll() is None:
            self.interrupt()
            try:
                self.p.wait(5)
            except subprocess.TimeoutExpired:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(self.p.pid, 2)
            try:
                self.p.wait(20)
            except subprocess.TimeoutExpired:
                os.killpg(self.p.pid, 9)
        if self.log:
            self.log.close()
