"""The trajectory cost function interface (base_local_planner TrajectoryCostFunction style).

Each cost has ``scale``, ``prepare(ctx) -> bool`` (False: skip this cycle) and ``score(trajs) -> (S,)``
where a negative value rejects the trajectory. Lower is better; the planner sums ``scale * score``.
A trajectory's score may not depend on the other trajectories of the set (the planner scores subsets).
A cost that is expensive per trajectory may also offer ``lower_bound(trajs)``: (S,) values no greater
than the scores, REJECT only where ``score`` rejects too (or None: no bound this time); the planner then
scores exactly only the trajectories that could still win. Such a cost scores poses one by one
(``pose_scores``: a trajectory's score is the max over its poses, REJECT if any pose is bad) and names
the pose most likely to carry a trajectory's max (``probe_steps``), whose cost is a tighter bound.
"""

from __future__ import annotations

import numpy as np

from master_side.planning.local.scoring_context import ScoringContext
from master_side.planning.local.trajectories import Trajectories

REJECT = -1.0


class CostFunction:
    """Base: a named, scaled trajectory score."""

    name = "Cost"

    def __init__(self, scale: float = 1.0):
        self.scale = float(scale)
        self.ctx: ScoringContext | None = None

    def prepare(self, ctx: ScoringContext) -> bool:
        self.ctx = ctx
        return True

    def score(self, trajs: Trajectories) -> np.ndarray:
        raise NotImplementedError

    def lower_bound(self, trajs: Trajectories) -> np.ndarray | None:
        return None

    def pose_scores(self, trajs: Trajectories, steps: np.ndarray, rows: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
        """(cost, bad) of single poses ``trajs.poses[rows, steps]`` (costs with a ``lower_bound``)."""
        raise NotImplementedError

    def probe_steps(self, trajs: Trajectories, rows: np.ndarray) -> np.ndarray:
        """Per trajectory ``rows``, the pose whose cost bounds the trajectory's best from below."""
        raise NotImplementedError
