"""Helpers for bus tests: free ports, pinned loopback endpoints, child processes with line readers.

Every session here has multicast scouting OFF and explicit tcp/127.0.0.1 endpoints on free ports, so
parallel runs on one machine cannot cross-talk (the netns test is the exception: it tests the default).
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from common.zenoh_config import BusConfig
from deploy.stack.process_group import checkout_env
from tests.support import free_port  # noqa: F401

REPO = Path(__file__).resolve().parents[2]
PROCS = str(Path(__file__).with_name("procs.py"))


def wait_for(cond, timeout: float = 20.0, what: str = "condition", step: float = 0.02):
    """Poll ``cond()`` until truthy (returns its value) or fail after ``timeout`` seconds."""
    end = time.monotonic() + timeout
    while True:
        v = cond()
        if v:
            return v
        if time.monotonic() > end:
            pytest.fail(f"timed out after {timeout:.0f} s waiting for {what}")
        time.sleep(step)


def child_env(robot: str, **bus) -> dict[str, str]:
    """Environment for a child process: this checkout on PYTHONPATH, ZENAV_* from ``bus``."""
    env = checkout_env(drop_zenav=True)
    env.update(BusConfig(robot=robot, **bus).to_env())
    return env


class Child:
    """A child process whose stdout lines are collected by a thread (wait on them with ``expect``)."""

    def __init__(self, argv: list[str], env: dict[str, str]) -> None:
        self.argv = argv
        self.proc = subprocess.Popen(
            argv,
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            cwd=str(REPO),
            start_new_session=True,
        )
        self.lines: list[str] = []
        self._cv = threading.Condition()
        self._eof = False
        self._err: list[str] = []
        threading.Thread(target=self._read, args=(self.proc.stdout, True), daemon=True).start()
        threading.Thread(target=self._read, args=(self.proc.stderr, False), daemon=True).start()

    def _read(self, stream, is_out: bool) -> None:
        for line in stream:
            if is_out:
                with self._cv:
                    self.lines.append(line.rstrip("\n"))
                    self._cv.notify_all()
            else:
                self._err.append(line)
        if is_out:
            with self._cv:
                self._eof = True
                self._cv.notify_all()

    @property
    def stderr(self) -> str:
        return "".join(self._err[-40:])

    def expect(self, pred, timeout: float = 30.0, what: str = "a line", start: int = 0) -> str:
        """The first stdout line at index >= ``start`` satisfying ``pred`` (str -> bool), waiting for it;
        fails on timeout or exit. ``self.found`` is set to its index."""
        end = time.monotonic() + timeout
        i = start
        with self._cv:
            while True:
                while i < len(self.lines):
                    if pred(self.lines[i]):
                        self.found = i
                        return self.lines[i]
                    i += 1
                if self._eof:
                    break
                left = end - time.monotonic()
                if left <= 0:
                    pytest.fail(
                        f"{what}: nothing within {timeout:.0f} s from {self.argv[1:4]}; "
                        f"stdout:\n{self.lines[-10:]}\nstderr:\n{self.stderr}"
                    )
                self._cv.wait(min(left, 0.5))
        with contextlib.suppress(subprocess.TimeoutExpired):
            self.proc.wait(5)
        pytest.fail(
            f"{what}: process {self.argv[1:4]} exited ({self.proc.returncode}); "
            f"stdout:\n{self.lines[-10:]}\nstderr:\n{self.stderr}"
        )

    def wait(self, timeout: float = 60.0) -> int:
        return self.proc.wait(timeout)

    def kill(self, sig: int = signal.SIGKILL) -> None:
        if self.proc.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(self.proc.pid, sig)

    def stop(self) -> None:
        self.kill(signal.SIGKILL)
        with contextlib.suppress(subprocess.TimeoutExpired):
            self.proc.wait(10)


def proc_argv(role: str, *args: str) -> list[str]:
    return [sys.executable, PROCS, role, *args]
