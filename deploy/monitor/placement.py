"""Where scans and clouds are drawn: as rviz draws them, in a fixed frame through the transform *at their stamp*.

Drawn in their sensor's own frame, Rerun would move them with the newest transform it has; with scans and TF
throttled apart, a scan taken before a turn was drawn turned with the robot (a line of points outside the
room, issue 31). So the monitor keeps every transform it receives (before throttling) and places each sensor
message when TF reaches its stamp. Pure: no rerun, no zenoh.
"""

from __future__ import annotations

import contextlib
import time
from typing import Callable

from common import messages as m
from common.geometry import Transform
from common.tf_buffer import ExtrapolationError, TFBuffer, TFError

FIXED_FRAME = "odom"  # rviz's fixed frame for the drawing: continuous, unlike map
PLACE_WAIT_S = 0.5  # a scan waits this long (wall) for TF to reach its stamp, then is drawn in its own frame
# ... and this long for its frame to be connected to the fixed frame at all: the sensor's latched static
# transform can come seconds after the first scans on a loaded machine (a CI run: 0.5 s was not enough, and an
# early scan of a recording was drawn 0.35 m below and 0.1 m behind where its playback drew it). A sensor whose
# frame never connects is then drawn in its own frame once per CONNECT_WAIT_S (the newest message each time).
CONNECT_WAIT_S = 3.0


class Placement:
    def __init__(self, fixed_frame: str = FIXED_FRAME, wait_s: float = PLACE_WAIT_S,
                 clock: Callable[[], float] = time.monotonic, connect_wait_s: float = CONNECT_WAIT_S) -> None:
        self.fixed_frame, self.wait_s, self.clock = fixed_frame, wait_s, clock
        self.connect_wait_s = connect_wait_s
        self.tf = TFBuffer(cache_time=10.0)
        self._awaiting: dict[str, tuple[float, m.Header, Callable[[], None]]] = {}  # entity -> (since, ...)

    def remember(self, msg: m.TFMessage, static: bool) -> None:
        for ts in msg.transforms:
            with contextlib.suppress(ValueError):  # a malformed edge is the TF logger's to report
                self.tf.set_transform(ts, static=static)

    def place(self, entity: str, header: m.Header, submit: Callable[[], None]) -> None:
        """``submit`` now if TF reaches ``header``'s stamp, else from ``due`` when it does (the newest per entity,
        at most ``wait_s``, or ``connect_wait_s`` while its frame is not connected to the fixed frame): a scan
        usually arrives before the odometry of its instant, and placed with an older transform it would land
        where the robot was (and differ between a run and its playback)."""
        if self.placeable(header):
            self._awaiting.pop(entity, None)
            submit()
        else:
            since = self._awaiting[entity][0] if entity in self._awaiting else self.clock()
            self._awaiting[entity] = (since, header, submit)

    def due(self, flush_all: bool = False) -> list[Callable[[], None]]:
        """The submits whose transform has come, or whose wait is over (all with ``flush_all``)."""
        now, out = self.clock(), []
        for entity, (since, header, submit) in list(self._awaiting.items()):
            wait = self._wait(header)
            if flush_all or wait is None or now - since > wait:
                del self._awaiting[entity]
                out.append(submit)
        return out

    def placeable(self, header: m.Header) -> bool:
        return self._wait(header) is None

    def _wait(self, header: m.Header) -> float | None:
        """None when the message can be drawn now; else how long it may wait for TF: ``wait_s`` for TF to reach
        its stamp, ``connect_wait_s`` for its frame to be connected to the fixed frame at all (the sensor's
        static transform can come after its first scans, as in a playback). Without any fixed frame it is
        drawn at once, in its own frame."""
        try:
            self.tf.lookup(self.fixed_frame, header.frame_id, header.stamp)
            return None
        except ExtrapolationError:  # not yet
            return self.wait_s
        except TFError:  # not connected yet, or never: no fixed frame at all
            return self.connect_wait_s if self.fixed_frame in self.tf.frames() else None

    def at_stamp(self, header: m.Header) -> tuple[str, Transform] | None:
        """(fixed frame, transform from ``header``'s frame into it at its stamp); None when TF does not have it
        (the points are then drawn in their own frame)."""
        try:
            return self.fixed_frame, self.tf.lookup(self.fixed_frame, header.frame_id, header.stamp).transform
        except TFError:
            return None
