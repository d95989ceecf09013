"""Keyframes: the latest state of rarely logged entities, logged again while it stays unchanged.

Rerun's gRPC server (``--serve-web``) keeps a history for viewers that connect later, up to its memory
limit; beyond it the oldest *temporal* messages go first (static data and blueprints stay). A map that
a map server latched once is logged once: after an hour of scans and costmaps it is dropped, and a page
opened then shows no map. Re-issuing the last logging call of such entities every ``period`` seconds
(wall time, with the message's own stamp) keeps them inside the history window; an entity logged more
often than that never is.
"""

from __future__ import annotations

import time
from typing import Callable

# message types published once or rarely: the latched map, the current goal, the global plan
KINDS = ("OccupancyGrid", "PoseStamped", "Path")


class Keyframes:
    def __init__(self, period: float, kinds: tuple[str, ...] = KINDS,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.period, self.kinds, self.clock = period, kinds, clock
        self._last: dict[str, tuple[float, float | None, Callable[[], None]]] = {}  # entity -> (t, stamp, fn)
        self.refreshed = 0

    def note(self, entity: str, kind: str, stamp: float | None, fn: Callable[[], None]) -> None:
        """A logging call of ``entity`` (the newest one wins)."""
        if self.period > 0 and kind in self.kinds:
            self._last[entity] = (self.clock(), stamp, fn)

    def due(self) -> list[tuple[str, tuple[float | None, Callable[[], None]]]]:
        """(entity, (stamp, fn)) of the entities not logged for ``period`` seconds (as ``Throttle.due``);
        marked as logged now."""
        now, out = self.clock(), []
        for entity, (t, stamp, fn) in list(self._last.items()):
            if now - t >= self.period:
                self._last[entity] = (now, stamp, fn)
                out.append((entity, (stamp, fn)))
        self.refreshed += len(out)
        return out
