"""ScoredSamplingPlanner: sum of scaled costs over all samples at once; best = lowest total.

Like base_local_planner's SimpleScoredSamplingPlanner, costs run in order and a trajectory rejected by
one cost (negative score) is out. When every trajectory is rejected, the report names the cost that
rejected most of them ("why not moving"), counted as ROS does (a cost only sees the trajectories the
earlier ones left).

A cost with a ``lower_bound`` (the footprint obstacle cost) is first summed at its bound; it is then
scored exactly only for the trajectories whose bounded total could still be the lowest (branch and
bound: cheapest bound first, until every remaining bound is above the best exact total). The winner is
the one the exhaustive sum picks (same totals, same float additions, lowest index on ties); in
``total``, trajectories that could not win keep their bounded total and ``rejected_by`` counts only
the trajectories that were scored.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

import numpy as np

from master_side.planning.local.cost_base import REJECT, CostFunction
from master_side.planning.local.scoring_context import ScoringContext
from master_side.planning.local.trajectories import Trajectories

FIRST_EXACT = 2  # trajectories scored exactly before the bounds are tightened
CHUNK = 8  # trajectories scored exactly per round after that
PROBE_MAX = 96  # trajectories whose bound is tightened at one pose each, per round


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
        alive = np.ones(n, dtype=bool)
        rejected: Counter[str] = Counter()
        parts = []  # [cost, scores or lower bounds, bounded?] in cost order
        for cost in self.costs:
            if cost.scale == 0.0 or not alive.any() or not cost.prepare(ctx):
                continue
            lower = cost.lower_bound(trajs)
            s = cost.score(trajs) if lower is None else lower
            neg = (s < 0) & alive
            if neg.any():
                rejected[cost.name] += int(neg.sum())
                alive &= ~neg
            parts.append([cost, s, lower is not None])
        total = _sum(parts, slice(None), n)
        if any(p[2] for p in parts) and alive.any():
            best = _branch_and_bound(trajs, parts, alive, total, rejected)
        else:
            best = int(np.argmin(np.where(alive, total, np.inf))) if alive.any() else -1
        total[~alive] = np.inf
        if n == 0:
            return ScoreResult(-1, total, {}, "no velocity sample is feasible")
        if best < 0:  # rare (the robot is stuck): count the rejections exactly for the report
            return self.score_exhaustive(trajs, ctx)
        return ScoreResult(best, total, dict(rejected), "")

    def score_exhaustive(self, trajs: Trajectories, ctx: ScoringContext) -> ScoreResult:
        """Every cost scores every trajectory the earlier costs left (the reference)."""
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


def _sum(parts: list, idx, n: int) -> np.ndarray:
    """Totals of trajectories ``idx``, added cost by cost in order (the exhaustive sum's additions)."""
    total = np.zeros(n)[idx]
    for cost, s, _ in parts:
        total += cost.scale * s[idx]
    return total


def _branch_and_bound(trajs: Trajectories, parts: list, alive: np.ndarray, total: np.ndarray,
                      rejected: Counter) -> int:
    """Score the bounded costs exactly where needed; returns the best index (-1: all rejected).
    ``alive``, ``total`` and ``rejected`` are updated in place (``total`` exact where scored)."""
    n, t = len(trajs), trajs.n_poses
    exact, probed = np.zeros(n, bool), np.zeros(n, bool)
    best, best_total = -1, np.inf
    bounded = [p for p in parts if p[2]]
    none = np.zeros(0, np.intp)
    while True:
        cand = np.flatnonzero(alive & ~exact & (total <= best_total))
        if cand.size == 0:
            return best
        order = cand[np.argsort(total[cand], kind="stable")]
        if best < 0 and not probed.any():  # first round: the cheapest bounds exactly, the next probed
            take, probe = order[:FIRST_EXACT], order[FIRST_EXACT:PROBE_MAX]
        else:
            probe = order[~probed[order]][:PROBE_MAX] if order.size > CHUNK else none
            take = order[:CHUNK] if probe.size == 0 else none
        k = take.size
        for p in bounded:
            cost = p[0]
            steps = np.concatenate((np.tile(np.arange(t), k), cost.probe_steps(trajs, probe)))
            c, bad = cost.pose_scores(trajs, steps, np.concatenate((np.repeat(take, t), probe)))
            s_take = c[:k * t].reshape(k, t).max(axis=1, initial=0.0)
            s_take[bad[:k * t].reshape(k, t).any(axis=1)] = REJECT
            s_probe = np.where(bad[k * t:], REJECT, c[k * t:])
            for idx, s in ((take, s_take), (probe, s_probe)):
                neg = s < 0
                if neg.any():
                    rejected[cost.name] += int(neg.sum())
                    alive[idx[neg]] = False
            p[1][take] = s_take
            p[1][probe] = np.maximum(p[1][probe], s_probe)
        both = np.concatenate((take, probe))
        total[both] = _sum(parts, both, n)
        exact[take] = True
        probed[probe] = True
        ok = take[alive[take]]
        if ok.size:
            m = total[ok].min()
            j = ok[total[ok] == m].min()  # lowest index on ties, as argmin over all
            if total[j] < best_total or (total[j] == best_total and j < best):
                best, best_total = int(j), float(total[j])
