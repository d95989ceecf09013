"""ScoredSamplingPlanner: sum of scaled costs over all samples at once; best = lowest total.

Like base_local_planner's SimpleScoredSamplingPlanner, costs run in order and a trajectory rejected by
one cost (negative score) is not scored by the later ones. When every trajectory is rejected, the
report names the cost that rejected most of them ("why not moving").
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

import numpy as np

from master_side.planning.local.costs import CostFunction
from master_side.planning.local.map_grid import ScoringContext
from master_side.planning.local.trajectories import Trajectories


@dataclass(frozen=True)
class ScoreResult:
    best: int  # index into the trajectories, -1 if all were rejected
    total: np.ndarray  # (S,) summed cost, inf where rejected
    rejected_by: dict[str, int]  # cost name -> number of trajectories it rejected
    reason: str  # "" when a trajectory was found


class ScoredSamplingPlanner:
    def __init__(self, costs: list[CostFunction]):
        self.costs = list(costs)

    def score(self, trajs: Trajectories, ctx: ScoringContext) -> ScoreResult:
        n = len(trajs)
        total = np.zeros(n)
        alive = np.ones(n, dtype=bool)
        rejected: Counter[str] = Counter()
        for cost in self.costs:
            if cost.scale == 0.0 or not alive.any() or not cost.prepare(ctx):
                continue
            idx = np.flatnonzero(alive)
            s = cost.score(trajs.subset(idx) if idx.size < n else trajs)
            neg = s < 0
            if neg.any():
                rejected[cost.name] += int(neg.sum())
                alive[idx[neg]] = False
            total[idx[~neg]] += cost.scale * s[~neg]
        total[~alive] = np.inf
        if n == 0:
            return ScoreResult(-1, total, {}, "no velocity sample is feasible")
        if not alive.any():
            name, count = rejected.most_common(1)[0]
            detail = ", ".join(f"{k} {v}" for k, v in rejected.most_common())
            return ScoreResult(
                -1,
                total,
                dict(rejected),
                f"all {n} trajectories rejected, mostly by {name} ({count}; {detail})",
            )
        return ScoreResult(int(np.argmin(total)), total, dict(rejected), "")
