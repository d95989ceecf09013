"""A publication sent from its own thread: ``publish`` never waits on the network.

A robot-side node publishes its state (the simulator's collision and motor state, the collision monitor's
state, the base driver's motor state) from its control loop, which must keep its period whatever the link
to the master does. Such a publisher hands each message to this sender: the newest message is kept, older
unsent ones are superseded (these are states: only the latest counts), and one thread puts it. States
are not ``reliable`` (common.bus.Node.publisher says why), so a put waits at most Zenoh's
``wait_before_drop``; the thread keeps even that, and a slow serialisation, off the loop. Late and
congested subscribers still get the latest by the latched query.
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
        self.thread = threading.Thread(target=self._run, name=f"send {name}", daemon=True)
        self.thread.start()

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
