"""Waiting on a condition, never on a fixed sleep (tests and benches)."""

from __future__ import annotations

import time
from typing import Any, Callable

from common.ports import free_port

__all__ = ["free_port", "wait_until"]


def wait_until(cond: Callable[[], Any], timeout: float, what: str = "condition", period: float = 0.01,
               alive: Callable[[], str] | None = None) -> Any:
    """Poll ``cond()`` until it is truthy (its value is returned) or fail after ``timeout`` wall seconds.

    ``alive()`` returning a non-empty text (e.g. "robot.log exited: ...") fails at once with it."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        v = cond()
        if v:
            return v
        if alive is not None and (dead := alive()):
            raise AssertionError(f"{dead} while waiting for {what}")
        time.sleep(period)
    raise AssertionError(f"timed out after {timeout} s waiting for {what}")
