"""Simulated sonar ring: each sonar reports the nearest echo within its cone (``SonarArray``, metres).

Each sonar is a fan of ``rays`` beams over its cone (``SonarRingParams.fov``), cast by the engine's own
laser (exact grid casts, or MuJoCo's rays); the reading is the nearest hit plus gaussian noise, and the
ring's ``range_max`` when nothing is within it (what a Pioneer reports for a sonar with no echo).
Specular reflection (a wall at a glancing angle returning no echo) is not modelled.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from common.config import param
from common.geometry import Pose2D
from common.messages import Header, SonarArray
from robot_side.sim.laser import Laser, LaserParams
from robot_side.sonar.geometry import SonarRingParams

__all__ = ["SimSonarParams", "SimSonar"]


@dataclass(frozen=True)
class SimSonarParams:
    rate: float = param(10.0, lo=0.1, hi=100.0, unit="Hz",
                        doc="readings published per second (a P2OS SIP carries sonar readings every 100 ms)")
    rays: int = param(7, lo=1, hi=100, doc="beams cast across each sonar's cone")
    z: float = param(0.2, lo=0.0, hi=10.0, unit="m", doc="height of the ring; only taller obstacles echo")
    noise_std: float = param(0.01, lo=0.0, hi=1.0, unit="m", doc="gaussian noise on each echo")
    frame_id: str = param("base_link", doc="frame of the readings (the ring's geometry is in the base frame)")
    topic: str = param("sonar", doc="bus topic (the P2OS node's)")
    seed: int = param(4, lo=0, doc="noise RNG seed")


class SimSonar:
    """Renders a ring's readings. ``make_laser(params, shared)`` builds one engine laser for a sonar's fan;
    ``shared`` is the first such laser (None for the first), whose precomputed world it may reuse."""

    def __init__(self, ring: SonarRingParams, p: SimSonarParams,
                 make_laser: Callable[[LaserParams, Laser | None], Laser]):
        self.ring, self.p = ring, p
        half = ring.fov / 2.0
        self.fans: list[Laser] = []
        for i, (x, y, heading) in enumerate(ring.units):
            lp = LaserParams(angle_min=-half, angle_max=half, samples=max(p.rays, 2), range_min=0.0,
                             range_max=ring.range_max, noise_std=0.0, rate=p.rate, x=x, y=y, z=p.z, yaw=heading,
                             frame_id=f"sonar_{i}", seed=p.seed)
            if p.rays == 1:  # one beam on the axis
                lp = dataclasses.replace(lp, angle_min=-1e-6, angle_max=1e-6)
            self.fans.append(make_laser(lp, self.fans[0] if self.fans else None))
        self.rng = np.random.default_rng(p.seed)

    def refresh(self) -> None:
        """Re-read the world (after ``World.add_box``): once, shared by every fan that shares it."""
        if not self.fans:
            return
        first = self.fans[0]
        first.refresh()
        if hasattr(first, "cells"):  # grid casts (the kinematic engine); MuJoCo's rays keep nothing
            for fan in self.fans[1:]:
                fan.cells = first.cells

    def ranges(self, robot: Pose2D) -> np.ndarray:
        """Each sonar's reading, metres (``range_max`` for no echo)."""
        rmax = self.ring.range_max
        out = np.array([float(np.min(fan.ranges_exact(robot))) for fan in self.fans])
        echo = np.isfinite(out) & (out < rmax)
        if self.p.noise_std > 0:
            out[echo] += self.rng.normal(0.0, self.p.noise_std, int(echo.sum()))
        out[~echo] = rmax
        return np.clip(out, 0.0, rmax)

    def reading(self, robot: Pose2D, stamp: float) -> SonarArray:
        return SonarArray(Header(stamp, self.p.frame_id), tuple(float(r) for r in self.ranges(robot)))
