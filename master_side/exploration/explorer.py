"""Where to go next while exploring (explore_lite's makePlan, our code), with its parameter names.

Each ``plan`` call (every 1/planner_frequency s) follows the current target while its frontier is there
(a frontier with a cell within ``commit_radius`` of the goal sent) and the robot is on its way; a new
target is chosen, the cheapest frontier not on the blacklist (within ``blacklist_radius`` of a
blacklisted centroid), when there is none yet, when move_base reached the goal (``goal_reached``), when
the frontier is gone (explored), or when its ``min_distance`` has not shrunk for ``progress_timeout`` s
(blacklisted; zenav's ``progress_travel``: driving on its way counts too, for a while; a frontier still
there after its goal was reached keeps the clock it had, as explore_lite
keeps its previous goal's, and is blacklisted when its goal is reached a second time with it no nearer).
explore_lite picks the cheapest every cycle: as SLAM's map grew, frontiers of near-equal cost traded
places and the robot was sent back and forth across office02. A goal
move_base aborts is blacklisted too (``goal_failed``). No frontier left (or all blacklisted) for
``done_timeout`` s: done; meanwhile ``wait`` (explore_lite ends on one search: a last frontier blacklisted
early ended a run in the mall at 2.5 % known; the node looks around while it waits, and SLAM's map grows).
Goals failing one after another while the robot stays where it is (``stuck_failures``) end exploration as
stuck (``stuck`` says why): the robot cannot move, and giving up frontier after frontier would end it as
if the building were explored.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from common.config import param
from master_side.exploration.frontiers import Frontier

STUCK_RADIUS = 0.2  # m: failures with the robot this near the first of them count as one place


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
    commit_radius: float = param(1.0, lo=0.0, hi=100.0, unit="m",
                                 doc="zenav's: the current target's frontier is the one with a cell this near its "
                                     "goal; followed until reached, gone, failed or stuck")
    look_around: bool = param(True, doc="zenav's: a full turn in place (four quarter turns) before the first "
                                        "search, so the sensor has seen all around the start: a forward laser or "
                                        "a camera leaves the space behind it unknown, and that frontier, "
                                        "running under the robot, gets no nearer by driving")
    circumscribed_radius: float = param(0.36, lo=0.0, hi=10.0, unit="m",
                                        doc="zenav's: goals this clear of walls where one is near, so the robot can "
                                            "turn to face the frontier (the P3-AT's, from the tutorial's footprint)")
    progress_travel: float = param(1.0, lo=0.0, hi=100.0, unit="m",
                                   doc="zenav's: a target whose frontier got no nearer is still progressing while "
                                       "the robot gets this far from where it last progressed within each "
                                       "progress_timeout, for at most 4 progress_timeouts (the way round a wall "
                                       "first leads away from the frontier: the mall's shops, their doors 4 m away "
                                       "by a 12 m path, were given up so); 0: explore_lite's rule")
    done_timeout: float = param(15.0, lo=0.0, hi=3600.0, unit="s",
                                doc="zenav's: nothing left to go to for this long ends exploration (0: at once, "
                                    "explore_lite's rule); the robot looks around meanwhile")
    stuck_failures: int = param(3, lo=0, hi=1000,
                                doc="zenav's: this many goals in a row that move_base gives up on, the robot within "
                                    "STUCK_RADIUS of where the first of them failed, end exploration as stuck, with "
                                    "move_base's last reason (0: never). A robot boxed in by its local costmap "
                                    "(office02, the Kinect, 2026-12-01) blacklisted 26 frontiers in a row from one "
                                    "place and ended as if nothing were left")
    inscribed_radius: float = param(0.254, lo=0.0, hi=10.0, unit="m",
                                    doc="zenav's: free space nearer a wall is not free for the search (the "
                                        "P3-AT's, from the tutorial's footprint)")


@dataclass
class Decision:
    action: str  # "send" (a new goal), "keep" (the same target), "wait" (nothing now), "done" (nothing left)
    target: tuple[float, float] | None = None  # the frontier's centroid: what the blacklist holds
    frontier: Frontier | None = None
    why: str = ""


@dataclass
class Explorer:
    params: ExploreParams = field(default_factory=ExploreParams)
    blacklist: list[tuple[float, float]] = field(default_factory=list)
    target: tuple[float, float] | None = None  # the followed frontier's centroid (as last seen)
    goal: tuple[float, float] | None = None  # where the robot was sent for it
    _best_distance: float = math.inf
    _last_progress: float = 0.0
    _reached: tuple[float, float] | None = None  # the goal move_base last reached (until the next choice)
    _reached_at: tuple[float, float] | None = None  # the goal last reached, kept
    _reaches: int = 0  # how many times in a row a goal there was reached
    _idle_since: float | None = None  # when the search last began to find nothing to go to
    _nearer_at: float = 0.0  # when the followed frontier last got nearer
    _robot: tuple[float, float] | None = None  # the robot's last position given to ``plan``
    _mark: tuple[float, float] | None = None  # where it was at the last progress
    _failed_at: list[tuple[float, float]] = field(default_factory=list)  # the robot at each failure in a row
    stuck: str = ""  # why exploration cannot go on (stuck_failures), "" while it can
    # each blacklisting since the caller last took them (``take_blacklisted``): the centroid and why
    _news: list[tuple[tuple[float, float], str]] = field(default_factory=list)

    def _drop(self, point: tuple[float, float], why: str) -> None:
        self.blacklist.append(point)
        self._news.append((point, why))

    def take_blacklisted(self) -> list[tuple[tuple[float, float], str]]:
        """The frontiers blacklisted since the last call, each with why (for the log: a run that ends
        with frontiers left says which were given up and on what)."""
        out, self._news = self._news, []
        return out

    def blacklisted(self, point: tuple[float, float]) -> bool:
        r = self.params.blacklist_radius
        return any(math.hypot(point[0] - b[0], point[1] - b[1]) <= r for b in self.blacklist)

    def _followed(self, frontiers: list[Frontier]) -> Frontier | None:
        """The current target's frontier as it is now: the one with a cell nearest the goal sent, within
        ``commit_radius`` (frontiers without cells: by their goal)."""
        if self.goal is None:
            return None
        gx, gy = self.goal
        best, best_d = None, self.params.commit_radius
        for f in frontiers:
            if self.blacklisted(f.centroid):
                continue
            pts = f.cells if len(f.cells) else [f.goal]
            d = min(math.hypot(x - gx, y - gy) for x, y in pts)
            if d <= best_d:
                best, best_d = f, d
        return best

    def plan(self, frontiers: list[Frontier], now: float, robot: tuple[float, float] | None = None) -> Decision:
        """``robot``: where the robot is (the frontiers' frame), for ``progress_travel``."""
        self._robot = robot
        d = self._choose(frontiers, now)
        if d.action != "done":
            self._idle_since = None
            return d
        if self._idle_since is None:
            self._idle_since = now
        if now - self._idle_since < self.params.done_timeout:
            return Decision("wait", why=d.why)
        return d

    def _choose(self, frontiers: list[Frontier], now: float) -> Decision:
        cur = self._followed(frontiers)
        if cur is not None:
            if cur.min_distance < self._best_distance:
                self._progress(now, cur.min_distance)
            elif self._on_its_way(now):
                self._last_progress, self._mark = now, self._robot
            if now - self._last_progress <= self.params.progress_timeout:
                self.target = cur.centroid
                moved = math.hypot(cur.goal[0] - self.goal[0], cur.goal[1] - self.goal[1])
                if moved > self.params.commit_radius:  # the frontier moved on as the robot saw more
                    self.goal = cur.goal
                    return Decision("send", cur.centroid, cur, "the followed frontier moved")
                return Decision("keep", cur.centroid, cur)
            # no nearer for progress_timeout: explore_lite's rule
            self._drop(cur.centroid, f"no nearer for {self.params.progress_timeout:g} s "
                                     f"(still {cur.min_distance:.1f} m away)")
        self.target = self.goal = None
        reached, self._reached = self._reached, None
        for pick in frontiers:
            if self.blacklisted(pick.centroid):
                continue
            # The frontier of a goal just reached, still there (the sensor did not see it from the goal, or
            # SLAM did not take a scan while the robot stood): its progress clock runs on, as explore_lite's
            # for its previous goal. Reset here, it was sent again every second for good (the mall).
            # Reached there twice and no nearer: standing there once more shows nothing new (the mall: the same
            # goal went out every second until the progress timeout, the robot standing still for 30 s).
            again = reached is not None and math.dist(pick.goal, reached) <= self.params.commit_radius
            if again and pick.min_distance >= self._best_distance:
                if now - self._last_progress > self.params.progress_timeout or self._reaches >= 2:
                    how = "twice" if self._reaches >= 2 else \
                        f"and no nearer for {self.params.progress_timeout:g} s"
                    self._drop(pick.centroid, f"its goal reached {how}, the frontier still {pick.min_distance:.1f} m "
                                              "away")
                    continue
            else:
                self._progress(now, pick.min_distance)
                self._reaches = 0
            self.target, self.goal = pick.centroid, pick.goal
            return Decision("send", pick.centroid, pick)
        why = "no frontier left" if not frontiers else f"all {len(frontiers)} frontiers blacklisted"
        return Decision("done", why=why)

    def _progress(self, now: float, distance: float) -> None:
        self._last_progress = self._nearer_at = now
        self._best_distance, self._mark = distance, self._robot

    def _on_its_way(self, now: float) -> bool:
        """No nearer, but driving: ``progress_travel`` from where it last progressed, within
        4 ``progress_timeout`` of the frontier last getting nearer."""
        p = self.params
        return (p.progress_travel > 0 and self._robot is not None and self._mark is not None
                and math.dist(self._robot, self._mark) >= p.progress_travel
                and now - self._nearer_at <= 4 * p.progress_timeout)

    def goal_reached(self) -> None:
        """move_base reached the goal: the next plan chooses afresh (the same frontier, if it is still the
        best, keeps its progress clock)."""
        same = (self.goal is not None and self._reached_at is not None
                and math.dist(self.goal, self._reached_at) <= self.params.commit_radius)
        self._reaches = self._reaches + 1 if same else 1
        self._reached = self._reached_at = self.goal
        self.target = self.goal = None
        self._failed_at = []

    def goal_failed(self, target: tuple[float, float], robot: tuple[float, float] | None = None,
                    reason: str = "", no_plan: bool = False) -> None:
        """move_base gave up on the goal sent for ``target`` (the centroid then): that frontier never again,
        where it was and where it is now. ``robot``: where the robot stands; the ``stuck_failures``-th failure
        in a row from one place sets ``stuck`` (with move_base's ``reason``). ``no_plan``: move_base found no
        way there: the frontier is out of reach, which says nothing of the robot (not counted)."""
        self.blacklist.append(target)
        if self.target is not None and self.target != target:
            self.blacklist.append(self.target)
        self.target = self.goal = None
        if robot is None or no_plan:
            return
        if self._failed_at and math.dist(robot, self._failed_at[0]) > STUCK_RADIUS:
            self._failed_at = []
        self._failed_at.append(robot)
        n = self.params.stuck_failures
        if n and len(self._failed_at) >= n:
            self.stuck = (f"stuck at ({robot[0]:.2f}, {robot[1]:.2f}): {len(self._failed_at)} goals in a row failed "
                          f"with the robot there" + (f", the last: {reason}" if reason else ""))
