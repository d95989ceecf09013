"""Logging helpers shared by nodes (no bus import here)."""

from __future__ import annotations

import logging
import time


class RateLimitedLog:
    """At most one warning per ``period`` seconds; the ones held back are counted in the next."""

    def __init__(self, period: float = 5.0) -> None:
        self.period, self.last, self.suppressed = period, -float("inf"), 0

    def __call__(self, logger: logging.Logger, msg: str) -> None:
        now = time.monotonic()
        if now - self.last >= self.period:
            extra = f" (+{self.suppressed} similar)" if self.suppressed else ""
            logger.warning(msg + extra)
            self.last, self.suppressed = now, 0
        else:
            self.suppressed += 1
