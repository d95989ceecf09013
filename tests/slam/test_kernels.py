"""The compiled kernels give the bits of the numpy code they replaced (tests/slam/numpy_reference.py)."""

import numpy as np
import pytest

from common.geometry import Pose2D
from master_side.slam import kernels, map_kernels
from master_side.slam.grid import TiledGrid
from master_side.slam.gridslam import prepare_beams
from master_side.slam.scan_matcher import FieldSet, MotionPrior, ScanMatcher, make_field
from tests.slam.numpy_reference import NumpyMatcher, _flipped_parts, fill_field, integrate_flips
from tests.slam.room_grid import BOX, P, room_grid


def test_pairwise_sum_is_numpys_float32_sum():
    rng = np.random.default_rng(0)
    for n in [1, 2, 7, 8, 9, 15, 16, 17, 127, 128, 129, 130, 180, 248, 249, 257, 361, 1000, 1929, kernels.MAX_SUM]:
        rows = (rng.random((4, n)) * rng.choice([1.0, 100.0, 1e4])).astype(np.float32)
        ref = rows.sum(axis=-1)
        got = np.array([kernels.pairwise_sum(r, 0, n) for r in rows], np.float32)
        assert np.array_equal(got, ref), n
        assert kernels.pairwise_sum(rows.ravel(), n, n) == ref[1]  # an offset into a buffer


@pytest.mark.parametrize("stride", [1, 2, 3, 40, 60])  # beam counts 308, 154, 103, 8, 6: the sums' code paths
@pytest.mark.parametrize("with_prior", [True, False])
@pytest.mark.parametrize("window", [(0.3, 0.12), (0.9, 0.4), (0.0, 0.1), (0.2, 0.0)])
def test_match_many_equals_the_numpy_matcher(room_scan, with_prior, window, stride):
    truth = Pose2D(0.3, -0.2, 0.1)
    grids = [room_grid(room_scan, Pose2D(0.3 + 0.04 * i, -0.2, 0.1 - 0.02 * i)) for i in range(3)]
    scan = room_scan(truth)
    scan.ranges[::7] = np.inf  # missing beams: an odd beam count
    pts = prepare_beams(scan, P, Pose2D()).match[::stride]
    assert len(pts) == {1: 308, 2: 154, 3: 103, 40: 8, 60: 6}[stride]
    rng = np.random.default_rng(7)
    n = 7
    starts = truth.as_array() + rng.normal(0, [0.1, 0.1, 0.05], (n, 3))
    starts[-1, :2] += 4.0  # far off the map: beams beyond the window's edge
    fs = FieldSet([make_field(grids[i % 3].window(*BOX), P) for i in range(n)])
    prior = MotionPrior(starts + rng.normal(0, 0.02, (n, 3)), rng.uniform(0.1, 1, n), rng.uniform(1, 3, n)) \
        if with_prior else None
    got = ScanMatcher(P).match_many(fs, starts, pts, window, prior)
    ref = NumpyMatcher(P).match_many(fs, starts, pts, window, prior)
    assert np.array_equal(got[0], ref[0]) and np.array_equal(got[1], ref[1])
    assert got[1].dtype == ref[1].dtype
    moved = np.abs(got[0] - starts).max(axis=1)
    assert (moved > 0).sum() >= n - 1  # the test exercises the search, not a no-op


def test_single_match_equals_the_numpy_matcher(room_scan):
    truth = Pose2D(-0.5, 0.4, -0.3)
    fld = make_field(room_grid(room_scan, truth).window(*BOX), P)
    pts = prepare_beams(room_scan(truth), P, Pose2D()).match
    start = truth.as_array() + [0.12, -0.08, 0.04]
    pose, score = ScanMatcher(P).match(fld, start, pts)
    ref_pose, ref_score = NumpyMatcher(P).match(fld, start, pts)
    assert np.array_equal(pose, ref_pose) and score == ref_score
    assert np.abs(pose[:2] - [truth.x, truth.y]).max() < 0.03


def test_tile_fields_equal_the_numpy_distance_transform():
    from master_side.slam.field import COARSE, FAR, coarse_of, inner_squared_distances, kernel_table

    rng = np.random.default_rng(11)
    r, t = P.field_radius, 64
    occ = rng.random((5, t + 2 * r, t + 2 * r)) < np.array([0.0, 0.002, 0.02, 0.2, 1.0])[:, None, None]
    logodds = np.where(occ, rng.uniform(0.01, 4, occ.shape), rng.uniform(-3, 0, occ.shape)).astype(np.float32)
    table = kernel_table(P.delta, P)
    fine, coarse = np.full((8, t, t), -1, np.float32), np.full((8, t // COARSE, t // COARSE), -1, np.float32)
    slots = np.array([6, 1, 3, 0, 7])
    at = np.full(5, r, np.int64)
    map_kernels.tile_fields(logodds, np.arange(5), at, at, r, FAR, table, COARSE, fine, coarse, slots)
    d = inner_squared_distances(occ, r)
    assert np.array_equal(fine[slots], table[d]) and np.array_equal(coarse[slots], table[coarse_of(d)])
    assert len(np.unique(fine[slots[2]])) > 5  # distances of every size occur


def test_field_fill_equals_numpy():
    rng = np.random.default_rng(4)
    for t, pad, (nty, ntx) in [(64, 8, (1, 1)), (64, 8, (3, 5)), (16, 24, (4, 2)), (16, 24, (1, 7))]:
        pool = rng.random((40, t, t)).astype(np.float32)
        slots = rng.integers(0, 40, (nty, ntx))
        out, ref = np.full((2, nty * t + 2 * pad, ntx * t + 2 * pad), np.nan, np.float32)
        map_kernels.fill_field(out, pool, slots, pad)
        fill_field(ref, pool, slots, pad)
        assert np.array_equal(out, ref)


def test_integration_equals_numpy(room_scan):
    from master_side.slam.grid import TILE
    from master_side.slam.gridslam import integrate_flips as compiled

    rng = np.random.default_rng(2)
    grid = TiledGrid(P.delta, halo=P.field_radius)
    win = grid.window(*BOX)
    ref = grid.window(*BOX)
    changed = 0
    for k in range(12):
        truth = Pose2D(*rng.normal(0, [0.5, 0.5, 1.0]))
        beams = prepare_beams(room_scan(truth), P, Pose2D(0.1, 0.0, 0.05))
        pose = truth.as_array()
        if k == 11:
            pose[:2] += 5.0  # beams off the window
        cells, flipped = compiled(win, pose, beams)
        ref_cells, ref_flipped = integrate_flips(ref, pose, beams)
        assert np.array_equal(win.data, ref.data)
        assert np.array_equal(np.sort(cells), np.unique(ref_cells))  # each touched cell, once
        assert np.array_equal(np.sort(flipped), np.unique(ref_flipped))
        changed += len(flipped)
        nx, ny = win.data.shape[1], win.data.shape[0]
        touched, parts = map_kernels.tile_parts(cells, flipped, nx, nx // TILE, ny // TILE, TILE, P.field_radius)
        ids = (ref_cells // nx // TILE) * (nx // TILE) + (ref_cells % nx) // TILE
        assert np.array_equal(np.flatnonzero(touched), np.unique(ids))
        ref_parts = _flipped_parts(ref_flipped, nx, P.field_radius)
        assert {divmod(int(t), nx // TILE) for t in np.flatnonzero(parts.any(axis=1))} == set(ref_parts)
        for (j, i), m in ref_parts.items():
            assert np.array_equal(parts[j * (nx // TILE) + i], m)
    assert changed > 100 and (win.data > 0).any() and (win.data < 0).any()
