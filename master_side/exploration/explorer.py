"""Where to go next while exploring (explore_lite's makePlan, our code), with its parameter names.

Each ``plan`` call (every 1/planner_frequency s) takes the frontiers, cheapest first, and picks the first
whose centroid is not on the blacklist (within ``blacklist_radius`` of a blacklisted goal). A new target
is a goal to send; the same target again is only watched: when its frontier's ``min_distance`` has not
shrunk for ``progress_timeout`` s, the target is blacklisted and the next one taken. A goal move_base
aborts is blacklisted too (``goal_failed``). No frontier left (or all blacklisted): exploration is done.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from common.config import param
from master_side.exploration.frontiers import Frontier


@dataclass(frozen=True)
class ExploreParams:
    planner_frequency: float = param(1.0, lo=0.01, hi=100.0, unit="Hz", doc="how often frontiers are searched")
    progress_timeout: float = param(30.0, lo=1.0, hi=3600.0, unit="s",
                                    doc="a target whose frontier got no nearer for this long is blacklisted")
    potential_scale: float = param(3.0, lo=0.0, hi=1e6,
                                   doc="weight of the frontier's distance (explore_lite's explore.launch: 3.0; its "
                                       "node's 1e-3 makes distance irrelevant: the robot thrashed between far "
                                       "frontiers of near-equal size, a new one every second)")
    orientation_scale: float = param(0.0, lo=0.0, hi=1e6, no_effect=True,
                                     doc="accepted; no effect (explore_lite does not use it either)")
    gain_scale: float = param(1.0, lo=0.0, hi=1e6, doc="weight of the frontier's size")
    min_frontier_size: float = param(0.5, lo=0.0, hi=100.0, unit="m", doc="smaller frontiers are ignored")
    visualize: bool = param(True, doc="publish the frontiers (explore/frontiers, a cloud of their cells) and the "
                                      "target (explore/target) for the monitor; on by default here (explore_lite: "
                                      "off), as the monitor is where a user watches exploration")
    blacklist_radius: float = param(0.5, lo=0.0, hi=100.0, unit="m",
                                    doc="zenav's: a target this near a blacklisted one is blacklisted too")
    look_around: bool = param(True, doc="zenav's: a full turn in place (four quarter turns) before the first "
                                        "search, so the sensor has seen all around the start: a forward laser or "
                                        "a camera leaves the space behind it unknown, and that frontier, "
                                        "running under the robot, gets no nearer by driving")
    inscribed_radius: float = param(0.254, lo=0.0, hi=10.0, unit="m",
                                    doc="zenav's: free space nearer a wall is not free for the search (the "
                                        "P3-AT's, from the tutorial's footprint)")


@dataclass
class Decision:
    action: str  # "send" (a new goal), "keep" (the same target), "done" (nothing left)
    target: tuple[float, float] | None = None  # the frontier's centroid: what the blacklist holds
    frontier: Frontier | None = None
    why: str = ""


@dataclass
class Explorer:
    params: ExploreParams = field(default_factory=ExploreParams)
    blacklist: list[tuple[float, float]] = field(default_factory=list)
    target: tuple[float, float] | None = None
    _best_distance: float = math.inf
    _last_progress: float = 0.0

    def blacklisted(self, point: tuple[float, float]) -> bool:
        r = self.params.blacklist_radius
        return any(math.hypot(point[0] - b[0], point[1] - b[1]) <= r for b in self.blacklist)

    def plan(self, frontiers: list[Frontier], now: float) -> Decision:
        for _ in range(len(frontiers) + 1):
            pick = next((f for f in frontiers if not self.blacklisted(f.centroid)), None)
            if pick is None:
                self.target = None
                why = "no frontier left" if not frontiers else f"all {len(frontiers)} frontiers blacklisted"
                return Decision("done", why=why)
            same = self.target is not None and math.hypot(pick.centroid[0] - self.target[0],
                                                          pick.centroid[1] - self.target[1]) < 1e-6
            if not same or pick.min_distance < self._best_distance:
                self._last_progress, self._best_distance = now, pick.min_distance
            if now - self._last_progress > self.params.progress_timeout:
                self.blacklist.append(pick.centroid)
                self.target = None
                continue  # the next frontier, at once (explore_lite plans again)
            self.target = pick.centroid
            return Decision("keep" if same else "send", pick.centroid, pick)
        return Decision("done", why="no frontier left")

    def goal_failed(self, target: tuple[float, float]) -> None:
        """move_base gave up on ``target``: never again."""
        self.blacklist.append(target)
        if self.target is not None and math.hypot(target[0] - self.target[0], target[1] - self.target[1]) < 1e-6:
            self.target = None
