"""The fast paths of navfn and DWA give what the straightforward versions give (random small maps)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from planning_helpers import P3AT_FOOTPRINT, inflate
from reference_impl import descend_reference, integrate_reference, map_grid_score_reference, propagate_reference

from common.geometry import Pose2D
from master_side.planning.gradient_path import descend
from master_side.planning.grid import LETHAL, NO_INFORMATION
from master_side.planning.local import DWAPlanner, DWAPlannerParams
from master_side.planning.local.costs import GoalAlign, GoalDistance, PathAlign, PathDistance
from master_side.planning.local.scoring_context import ScoringContext
from master_side.planning.local.trajectories import Trajectories, _integrate_constant, linspace_window, sample_grid
from master_side.planning.navfn import NavfnParams
from master_side.planning.potential import pad_costs, propagate


def _random_map(rng, n: int, res: float, unknown: bool = False) -> np.ndarray:
    g = np.zeros((n, n), np.uint8)
    for _ in range(int(rng.integers(0, 6))):
        r0, c0 = rng.integers(0, n, 2)
        h, w = rng.integers(2, 12, 2)
        g[r0:r0 + h, c0:c0 + w] = LETHAL
    g = inflate(g, res, inscribed=0.254, radius=0.45)
    if unknown:
        g[rng.integers(0, n, 20), rng.integers(0, n, 20)] = NO_INFORMATION
    return g


@pytest.mark.parametrize("seed", range(6))
def test_potential_matches_the_reference_wavefront(seed):
    rng = np.random.default_rng(seed)
    grid = _random_map(rng, int(rng.integers(20, 60)), 0.05, unknown=seed % 2 == 1)
    h, w = grid.shape
    free = np.argwhere(grid < 253)
    (sr, sc), (gr, gc) = free[rng.integers(len(free), size=2)]
    for p in (NavfnParams(), NavfnParams(use_quadratic=False), NavfnParams(use_dijkstra=False)):
        cost = pad_costs(p.cell_costs(grid))
        wp = w + 2
        heur = None
        if not p.use_dijkstra:
            rr, cc = np.mgrid[-1:h + 1, -1:w + 1]
            heur = (p.neutral_cost * np.hypot(rr - gr, cc - gc)).ravel()
        kw = dict(quadratic=p.use_quadratic, heuristic=heur, band=100.0, margin=759.0)
        src, stop = (sr + 1) * wp + sc + 1, (gr + 1) * wp + gc + 1
        got, cyc = propagate(cost, wp, src, stop, **kw)
        ref, ref_cyc = propagate_reference(cost, wp, src, stop, **kw)
        np.testing.assert_array_equal(got, ref)
        assert cyc == ref_cyc


@pytest.mark.parametrize("seed", range(6))
def test_path_descent_matches_the_reference_descent(seed):
    rng = np.random.default_rng(50 + seed)
    grid = _random_map(rng, int(rng.integers(30, 70)), 0.05, unknown=seed % 2 == 1)
    h, w = grid.shape
    p = NavfnParams()
    free = np.argwhere(grid < 253)
    sr, sc = free[rng.integers(len(free))]
    pot, _ = propagate(pad_costs(p.cell_costs(grid)), w + 2, (sr + 1) * (w + 2) + sc + 1)
    pot2d = pot.reshape(h + 2, w + 2)
    for gr, gc in free[rng.integers(len(free), size=6)]:
        for kw in ({}, {"grid_only": True}, {"step": 0.3}, {"max_steps": 7}):
            got = descend(pot2d, (gr + 1, gc + 1), 0.999 * p.neutral_cost, **kw)
            ref = descend_reference(pot2d, (gr + 1, gc + 1), 0.999 * p.neutral_cost, **kw)
            assert (got is None) == (ref is None)
            if ref is not None:
                np.testing.assert_array_equal(got, ref)


def test_constant_velocity_simulation_is_bit_identical():
    rng = np.random.default_rng(3)
    for trial in range(40):
        vy = linspace_window(-0.1, 0.1, 3) if trial % 2 else np.zeros(1)
        s = sample_grid(linspace_window(-0.5, 0.5, int(rng.integers(1, 12))), vy,
                        linspace_window(-1.0, 1.0, int(rng.integers(1, 12))))
        t, dt, start = int(rng.integers(1, 40)), float(rng.uniform(0.01, 0.1)), rng.uniform(-3, 3, 3)
        ref = integrate_reference(start, np.broadcast_to(s[:, None, :], (len(s), t, 3)), dt)
        np.testing.assert_array_equal(_integrate_constant(start, s, t, dt).poses, ref)


def _context(rng, res=0.025, n=80):
    grid = _random_map(rng, n, res, unknown=bool(rng.integers(2)))
    size = n * res
    xs = np.linspace(0.1 * size, 1.3 * size, 40)  # leaves the map: cut at the edge
    plan = np.column_stack((xs, 0.5 * size + 0.2 * size * np.sin(xs), np.zeros_like(xs)))
    pose = np.array([0.15 * size, 0.5 * size, rng.uniform(-1, 1)])
    ctx = ScoringContext(pose, np.zeros(3), grid, res, np.zeros(2), P3AT_FOOTPRINT, plan, plan[-1])
    _, _, inside = ctx.cells(plan[:, :2])
    ctx.plan = plan[: int(np.argmin(inside)) or len(plan)]
    ctx.goal = ctx.plan[-1]
    return ctx


@pytest.mark.parametrize("seed", range(8))
def test_map_grid_costs_match_the_point_by_point_version(seed):
    rng = np.random.default_rng(seed)
    ctx = _context(rng)
    samples = sample_grid(linspace_window(-0.6, 0.6, 7), np.zeros(1), linspace_window(-1.5, 1.5, 9))
    # long trajectories: some leave the map, some cross obstacles
    trajs = _integrate_constant(ctx.pose, samples, 30, 0.1)
    plain = Trajectories(trajs.poses.copy(), trajs.vels)  # no simulation cache: derived from the poses
    for cost in (PathDistance(), GoalDistance(), PathAlign(1.0, 0.325), GoalAlign(1.0, 0.325)):
        if cost.prepare(ctx):
            ref = map_grid_score_reference(cost, trajs)
            np.testing.assert_array_equal(cost.score(trajs), ref)
            np.testing.assert_array_equal(cost.score(plain), ref)


@pytest.mark.parametrize("seed", range(10))
def test_bounded_scoring_picks_what_the_exhaustive_sum_picks(seed):
    rng = np.random.default_rng(100 + seed)
    ctx = _context(rng, res=0.025 if seed % 3 else 0.05)
    planner = DWAPlanner(DWAPlannerParams(vx_samples=12, vth_samples=15, min_vel_x=-0.3,
                                          twirling_scale=0.05 * (seed % 2)))
    for _ in range(4):
        vel = np.array([rng.uniform(-0.2, 0.5), 0.0, rng.uniform(-0.8, 0.8)])
        trajs = planner._simulate(ctx.pose, vel, planner._samples(vel))
        fast = planner.scorer.score(trajs, ctx)
        ref = planner.scorer.score_exhaustive(Trajectories(trajs.poses, trajs.vels), ctx)
        assert fast.best == ref.best
        assert fast.reason == ref.reason
        if ref.best >= 0:
            assert fast.total[fast.best] == ref.total[ref.best]
            assert (fast.total >= ref.total[ref.best]).all()
        # every trajectory twice (reversed first): ties go to the lower index, as argmin does
        twice = Trajectories(np.concatenate((trajs.poses[::-1], trajs.poses)),
                             np.concatenate((trajs.vels[::-1], trajs.vels)))
        fast = planner.scorer.score(twice, ctx)
        ref = planner.scorer.score_exhaustive(Trajectories(twice.poses, twice.vels), ctx)
        assert fast.best == ref.best
        ctx.pose = ctx.pose + np.array([0.05, 0.0, 0.1])
        ctx._cache.clear()


@pytest.mark.parametrize("seed", range(4))
def test_dwa_drives_the_same_with_exhaustive_scoring(seed):
    rng = np.random.default_rng(200 + seed)
    ctx = _context(rng, n=100)
    runs = []
    for exhaustive in (False, True):
        planner = DWAPlanner(DWAPlannerParams(vx_samples=10, vth_samples=12, controller_frequency=10.0))
        if exhaustive:
            planner.scorer.score = planner.scorer.score_exhaustive
        planner.set_plan(ctx.plan)
        pose, vel, cmds = ctx.pose.copy(), (0.0, 0.0, 0.0), []
        for _ in range(15):
            r = planner.compute_velocity(Pose2D(*pose), vel, ctx.grid, ctx.resolution, (0.0, 0.0), P3AT_FOOTPRINT)
            cmds.append((r.cmd, r.ok, r.reason, r.n_samples))
            vel = r.cmd
            pose = pose + 0.1 * np.array([vel[0] * math.cos(pose[2]), vel[0] * math.sin(pose[2]), vel[2]])
        runs.append(cmds)
    assert runs[0] == runs[1]
