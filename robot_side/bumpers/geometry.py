"""Bumper segments of a rectangular base, as a Pioneer has them, and the points that put a press in a costmap.

A Pioneer 3's front and rear bumpers are each a row of segments (ARIA's robot parameters: 5 front, 5 rear),
reported in its SIP stall/bump bytes. Segments are numbered from the robot's left end (+y) to its right end
(our convention; ``BumperState``'s). ``pressed`` says which segments a contact point presses (the simulator,
which knows where it touches); ``press_points`` turns pressed segments into points in the base frame, as
kobuki's bumper2pc does, for an obstacle layer to mark: a forward laser or camera never sees what the rear
corner touches while turning, and the planner went on pushing the same way for good (office02).

The points lie ``offset`` beyond the bumper's face, outside the footprint and its padding: an obstacle layer
frees the cells under the footprint each update (footprint_clearing_enabled), and a mark under the robot
would also reject every trajectory. The end segments get a point beside the corner too (a flank that
touches there presses the end segment of a real bumper ring's corner piece).
Pure: no bus.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from common.config import param


@dataclass(frozen=True)
class BumperParams:
    front_x: float = param(0.254, lo=-5.0, hi=5.0, unit="m",
                           doc="the front bumper's face along base_link x (the P3-AT: half its 0.508 m body)")
    rear_x: float = param(-0.254, lo=-5.0, hi=5.0, unit="m", doc="the rear bumper's face along base_link x")
    half_width: float = param(0.254, lo=0.01, hi=5.0, unit="m", doc="half the bumpers' width")
    segments: int = param(5, lo=1, hi=7, doc="segments per bumper (ARIA's robot parameters: 5; a SIP byte has 7 bits)")
    reach: float = param(0.06, lo=0.0, hi=0.5, unit="m", doc="a contact this near a bumper's face presses it")

    def validate(self) -> None:
        if self.rear_x >= self.front_x:
            raise ValueError(f"rear_x {self.rear_x} must be behind front_x {self.front_x}")


def _segment(p: BumperParams, y: float) -> int:
    """The segment at lateral position ``y`` (clipped to the ends); 0 at the left end."""
    share = (p.half_width - y) / (2.0 * p.half_width)
    return int(np.clip(np.floor(share * p.segments), 0, p.segments - 1))


def pressed(p: BumperParams, contact: tuple[float, float] | None) -> tuple[tuple[bool, ...], tuple[bool, ...]]:
    """(front, rear) segments pressed by a contact at ``contact`` (x, y in the base frame); None: none."""
    front, rear = [False] * p.segments, [False] * p.segments
    if contact is not None:
        x, y = contact
        if x >= p.front_x - p.reach:
            front[_segment(p, y)] = True
        elif x <= p.rear_x + p.reach:
            rear[_segment(p, y)] = True
    return tuple(front), tuple(rear)


def press_points(p: BumperParams, front: tuple[bool, ...], rear: tuple[bool, ...], offset: float = 0.08,
                 z: float = 0.1, per_segment: int = 3) -> np.ndarray:
    """(N, 3) float32 points in the base frame for the pressed segments, ``offset`` beyond each face."""
    width = 2.0 * p.half_width / p.segments
    out: list[tuple[float, float]] = []
    for bumper, face, out_x in ((front, p.front_x, p.front_x + offset), (rear, p.rear_x, p.rear_x - offset)):
        for i, on in enumerate(bumper[:p.segments]):
            if not on:
                continue
            left = p.half_width - i * width
            out += [(out_x, left - (k + 0.5) * width / per_segment) for k in range(per_segment)]
            if i == 0:
                out.append((face, p.half_width + offset))
            if i == p.segments - 1:
                out.append((face, -p.half_width - offset))
    pts = np.zeros((len(out), 3), np.float32)
    if out:
        pts[:, :2] = out
        pts[:, 2] = z
    return pts


class PressLatch:
    """The segments pressed at any step since the last ``take``: a SIP reports its whole cycle (100 ms), and a
    simulator step blocked once between two reports must not be missed."""

    def __init__(self, p: BumperParams) -> None:
        self.p = p
        self._front, self._rear = [False] * p.segments, [False] * p.segments

    def note(self, contact: tuple[float, float]) -> None:
        front, rear = pressed(self.p, contact)
        self._front = [a or b for a, b in zip(self._front, front)]
        self._rear = [a or b for a, b in zip(self._rear, rear)]

    def take(self) -> tuple[tuple[bool, ...], tuple[bool, ...]]:
        out = tuple(self._front), tuple(self._rear)
        self._front, self._rear = [False] * self.p.segments, [False] * self.p.segments
        return out
