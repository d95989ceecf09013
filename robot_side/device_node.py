"""What the device drivers' nodes share (P2OS base, Hokuyo, S300, Kinect): a lost device ends the process.

``common.runner`` ends a node's process with ``exit_code`` once ``finished`` is set; the robot agent then
respawns it, which reopens the port. A node subclasses :class:`DeviceNode`, calls ``watch(period, check)``
once the device runs, and from ``check`` calls ``device_lost(...)`` — logged once, then the exit.
"""

from __future__ import annotations

import threading
from typing import Callable, TypeVar

EXIT_DEVICE_LOST = 1  # not 0 (a clean stop) and not a config error's status: the agent respawns


class DeviceNode:
    def __init__(self, node, exit_code: int = EXIT_DEVICE_LOST) -> None:
        self.node = node
        self.finished = threading.Event()
        self.exit_code = exit_code
        self._health = None

    @property
    def lost(self) -> bool:
        return self.finished.is_set()

    def watch(self, period: float, check: Callable[[], None]) -> None:
        """Run ``check`` every ``period`` seconds on the node's clock until ``unwatch``."""
        self._health = self.node.timer(period, check)

    def unwatch(self) -> None:
        if self._health is not None:
            self._health.cancel()
            self._health = None

    def device_lost(self, msg: str, *args) -> bool:
        """Log ``msg % args`` as an error the first time and finish the node; False when already reported."""
        if self.finished.is_set():
            return False
        self.node.log.error(msg, *args)
        self.finished.set()  # common.runner ends the process with exit_code
        return True


D = TypeVar("D", bound=DeviceNode)


def start_or_exit(name: str, make: Callable[[], D], errors: type[BaseException] | tuple) -> D:
    """``make()``, a connection error turned into one ``zenav NAME: why`` line and a non-zero exit."""
    try:
        return make()
    except errors as e:
        raise SystemExit(f"zenav {name}: {e}") from None
