"""A publication sent from its own thread: ``publish`` never waits on the network.

Zenoh blocks a reliable put while the send queue toward a peer is full, up to its ``wait_before_close``
(5 s) on a link that was just cut. A robot-side node publishing its state from its control loop (the
simulator's collision and motor state, the collision monitor's state, the base driver's motor state)
would freeze there exactly when the master is lost. Such a publisher hands each message to this sender:
the newest message is kept, older unsent ones are superseded (these are states: only the latest counts),
and one thread puts it. Late and congested subscribers still get the latest by the latched query.
"""

from __future__ import annotations

import threading
from collections.abc import Callable


class LatestSender:
    def __init__(self, put: Callable[[bytes], None], name: str) -> None:
        self._put, self._cv = put, threading.Condition()
        self._pending: bytes | None = None
        self._closed = False
        self.superseded = 0  # messages replaced before they were sent
        self._thread = threading.Thread(target=self._run, name=f"send {name}", daemon=True)
        self._thread.start()

    def send(self, data: bytes) -> None:
        with self._cv:
            if self._pending is not None:
                self.superseded += 1
            self._pending = data
            self._cv.notify()

    def _run(self) -> None:
        while True:
            with self._cv:
                while self._pending is None and not self._closed:
                    self._cv.wait()
                if self._closed:
                    return
                data, self._pending = self._pending, None
            self._put(data)  # may block (reliable, congested link): only this thread waits

    def close(self) -> None:
        with self._cv:
            self._closed = True
            self._cv.notify()
