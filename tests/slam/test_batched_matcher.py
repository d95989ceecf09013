"""The batched matcher and the tile field cache give exactly the per-particle reference results."""

import math

import numpy as np

from common.geometry import Pose2D
from master_side.slam.field import FAR, kernel_table, squared_distance_field
from master_side.slam.field_cache import FieldCache
from master_side.slam.gridslam import prepare_beams
from master_side.slam.scan_matcher import FieldSet, MotionPrior, ScanMatcher, make_field
from tests.slam.room_grid import BOX, P, room_grid


def _reference_scores(win, poses: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """The scalar scorer of one window: uint8 distance field, table lookups, a loop over poses."""
    fine = squared_distance_field(win.data > 0.0, P.field_radius)
    fine[0, :] = fine[-1, :] = FAR
    fine[:, 0] = fine[:, -1] = FAR
    tab = kernel_table(win.res, P)
    ny, nx = fine.shape
    out = []
    for x, y, th in poses:
        c, s = math.cos(th), math.sin(th)
        u = (c * pts[:, 0] - s * pts[:, 1] + x) / win.res - win.ix0 - 0.5
        v = (s * pts[:, 0] + c * pts[:, 1] + y) / win.res - win.iy0 - 0.5
        u0, v0 = np.floor(u), np.floor(v)
        fu, fv = (u - u0).astype(np.float32), (v - v0).astype(np.float32)
        i0 = np.clip(u0.astype(int), 0, nx - 2)
        j0 = np.clip(v0.astype(int), 0, ny - 2)
        a, b = tab[fine[j0, i0]], tab[fine[j0, i0 + 1]]
        cc, d = tab[fine[j0 + 1, i0]], tab[fine[j0 + 1, i0 + 1]]
        out.append(((a * (1 - fu) + b * fu) * (1 - fv) + (cc * (1 - fu) + d * fu) * fv).sum())
    return np.array(out, np.float32)


def test_vectorised_scores_equal_the_scalar_reference(room_scan):
    truth = Pose2D(0.3, -0.2, 0.1)
    win = room_grid(room_scan, truth).window(*BOX)
    pts = prepare_beams(room_scan(truth), P, Pose2D()).match
    rng = np.random.default_rng(3)
    poses = truth.as_array() + rng.normal(0, [0.05, 0.05, 0.03], (40, 3))
    ref = _reference_scores(win, poses, pts)
    got = ScanMatcher(P).score(make_field(win, P), poses, pts)
    assert np.array_equal(got, ref)


def test_batched_match_equals_one_particle_at_a_time(room_scan):
    truth = Pose2D(0.3, -0.2, 0.1)
    grid = room_grid(room_scan, truth)
    other = room_grid(room_scan, Pose2D(0.25, -0.1, 0.08))  # a different map per particle
    pts = prepare_beams(room_scan(truth), P, Pose2D()).match
    rng = np.random.default_rng(5)
    starts = truth.as_array() + rng.normal(0, [0.08, 0.08, 0.04], (5, 3))
    fields = [make_field((grid if i % 2 else other).window(*BOX), P) for i in range(5)]
    prior = MotionPrior(starts + 0.01, np.full(5, 0.4), np.full(5, 2.0))
    m = ScanMatcher(P)
    poses, scores = m.match_many(FieldSet(fields), starts, pts, (0.3, 0.12), prior)
    for i in range(5):
        one = MotionPrior(prior.mean[i], 0.4, 2.0)
        pose, score = m.match(fields[i], starts[i], pts, (0.3, 0.12), one)
        assert np.array_equal(pose, poses[i]) and score == scores[i]
    lls = m.log_likelihoods(FieldSet(fields), poses, pts)
    assert all(m.log_likelihood(fields[i], poses[i], pts) == lls[i] for i in range(5))
    assert np.abs(poses[:, :2] - [truth.x, truth.y]).max() < 0.03


def test_cached_tile_fields_equal_the_window_field(room_scan):
    grid = room_grid(room_scan, Pose2D(0.3, -0.2, 0.1))
    win = grid.window(*BOX)
    ref = make_field(win, P)
    cache = FieldCache(P)
    rng = grid.tile_range(*BOX)
    for scratch in (False, True):  # fresh buffers / reused ones
        fs = cache.fieldset([grid], [rng], scratch=scratch)
        fine, coarse = fs.views(0)
        assert np.array_equal(fine, ref.fine) and np.array_equal(coarse, ref.coarse)
    built = cache.built
    copy = grid.copy()  # a copy shares the occupancy stamps: nothing to rebuild
    cache.fieldset([copy], [rng])
    assert cache.built == built
    w2 = copy.window(*BOX)
    w2.data[70:72, 70:72] = 2.0  # new occupied cells: only the tiles that see them are rebuilt
    copy.store(w2, np.array([70 * w2.data.shape[1] + 70]), np.array([70 * w2.data.shape[1] + 70]))
    fs = cache.fieldset([copy], [rng])
    assert 1 <= cache.built - built <= 4
    assert np.array_equal(fs.views(0)[0], make_field(copy.window(*BOX), P).fine)
