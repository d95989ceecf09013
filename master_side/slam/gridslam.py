"""GridSlam: the Rao-Blackwellised particle filter of gmapping (one grid map per particle).

Per processed scan: sample every particle from the odometry motion model, scan-match it against
its own map (improved proposal), weight it by the match likelihood, resample when Neff is low,
then integrate the scan into each surviving map. Maps share unchanged tiles (copy-on-write) and
trajectories share their ancestry (a tree of ``TNode``).
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass

import numpy as np

from common.geometry import Pose2D
from common.messages import LaserScan, OccupancyGrid
from master_side.slam import map_kernels
from master_side.slam.field_cache import FieldCache
from master_side.slam.grid import LOG_ODDS, TiledGrid, Window, unique_tile_bytes
from master_side.slam.motion_model import MotionModel, compose_many
from master_side.slam.params import GMappingParams
from master_side.slam.particle_filter import needs_resampling, neff, normalized_weights, systematic_resample
from master_side.slam.scan_matcher import MotionPrior, ScanMatcher

CHUNK = 32  # particles matched together (memory of the batched search ~ CHUNK * window size)


class TNode:
    """One pose of a particle's trajectory; ``parent`` is the previous processed scan's node."""

    __slots__ = ("pose", "index", "parent")

    def __init__(self, pose: np.ndarray, index: int, parent: TNode | None):
        self.pose, self.index, self.parent = pose, index, parent


@dataclass
class Particle:
    pose: np.ndarray
    grid: TiledGrid
    weight: float = 0.0  # log weight since the last resampling
    weight_sum: float = 0.0  # log weight accumulated over the particle's ancestry
    node: TNode | None = None


@dataclass
class Beams:
    """One scan prepared in the base frame."""

    match: np.ndarray  # (M, 2) endpoints used for matching / weighting (lskip applied)
    hits: np.ndarray  # (H, 2) endpoints within the usable range (marked occupied)
    free: np.ndarray  # (F, 2) points along the beams up to the endpoint / usable range (marked free)
    ends: np.ndarray  # (E, 2) clipped beam ends, for the window extent
    origin: np.ndarray  # (2,) sensor position


def prepare_beams(scan: LaserScan, p: GMappingParams, laser: Pose2D, free: bool = True) -> Beams:
    """``free=False``: no free-space points (a scan that is only matched, not integrated)."""
    r = np.asarray(scan.ranges, float)
    a = scan.angles()
    valid: np.ndarray = np.isfinite(r) & (r > max(scan.range_min, 1e-3)) & (r < p.maxRange)
    usable = p.usable_range
    hit: np.ndarray = valid & (r < usable)
    length = np.minimum(r, usable)[valid]
    ca, sa = np.cos(a[valid]), np.sin(a[valid])
    ends = np.column_stack((length * ca, length * sa))
    if not free:
        hits = np.column_stack((r[hit] * np.cos(a[hit]), r[hit] * np.sin(a[hit])))
        m = laser.apply(hits[:: p.lskip + 1])
        return Beams(m, m[:0], m[:0], laser.apply(ends), np.array([laser.x, laser.y]))
    step = p.delta * 0.9
    n = np.maximum(np.floor((length - p.delta) / step).astype(np.int64), 0)
    beam = np.repeat(np.arange(len(n)), n)
    s = (np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)) * step
    free_pts = np.column_stack((s * ca[beam], s * sa[beam]))
    hits_all = np.column_stack((r[hit] * np.cos(a[hit]), r[hit] * np.sin(a[hit])))
    match = hits_all[:: p.lskip + 1]
    return Beams(laser.apply(match), laser.apply(hits_all), laser.apply(free_pts), laser.apply(ends),
                 np.array([laser.x, laser.y]))


def integrate_into(grid: TiledGrid, rng: tuple[int, int, int, int], pose: np.ndarray, beams: Beams) -> int:
    """Add the scan at ``pose`` to the grid's tiles in the tile range ``rng`` (points off it are
    dropped); returns the number of cells whose occupancy flipped."""
    return grid.integrate(rng, float(pose[0]), float(pose[1]), float(pose[2]), beams.free, beams.hits)


def integrate(win: Window, pose: np.ndarray, beams: Beams) -> np.ndarray:
    """Add the scan at ``pose`` to a dense window's log-odds (then ``TiledGrid.store`` it); returns
    the touched flat cell indices."""
    return integrate_flips(win, pose, beams)[0]


def integrate_flips(win: Window, pose: np.ndarray, beams: Beams) -> tuple[np.ndarray, np.ndarray]:
    """``integrate``, also returning the cells whose occupancy (log-odds > 0) changed."""
    ny, nx = win.data.shape
    mark = getattr(_scratch, "mark", None)
    if mark is None or mark.size < ny * nx:
        mark = _scratch.mark = np.zeros(max(ny * nx, 1 << 20), np.uint8)
    return map_kernels.integrate_scan(win.data.reshape(-1), nx, ny, win.ix0, win.iy0, win.res, float(pose[0]),
                                  float(pose[1]), math.cos(pose[2]), math.sin(pose[2]), beams.free, beams.hits,
                                  mark, *LOG_ODDS)


_scratch = threading.local()  # integrate_flips' zeroed cell marks, one buffer per thread


class GridSlam:
    def __init__(self, params: GMappingParams, laser: Pose2D | None = None,
                 rng: np.random.Generator | None = None, track_between: bool = False):
        self.p = params
        # offline refinement: scan-match every skipped scan against the best map (no map update);
        # between[i] = (last processed index, pose relative to that scan's pose)
        self.track_between = track_between
        self.between: dict[int, tuple[int, np.ndarray]] = {}
        self.last_index = 0
        self.laser = laser if laser is not None else Pose2D()  # base_link <- laser
        self.rng = rng if rng is not None else np.random.default_rng(params.seed)
        self.motion = MotionModel(params.srr, params.srt, params.str_, params.stt)
        self.matcher = ScanMatcher(params)
        self.fields = FieldCache(params)
        self._track_field: tuple | None = None
        self.particles: list[Particle] = []
        self.last_odom: Pose2D | None = None  # odometry at the last processed scan
        self.prev_odom: Pose2D | None = None  # odometry at the last scan
        self.last_stamp = -math.inf
        self.lin_acc = self.ang_acc = 0.0
        self.count = 0  # scans seen
        self.processed = 0
        self.resamples = 0
        self.last_neff = float(params.particles)

    # -- main entry ------------------------------------------------------------------------
    def process(self, stamp: float, odom: Pose2D, scan: LaserScan) -> bool:
        """Feed one scan with the odometry pose at its stamp; True if it was integrated."""
        index = self.count
        self.count += 1
        if self.prev_odom is not None:
            d = self.prev_odom.between(odom)
            self.lin_acc += math.hypot(d.x, d.y)
            self.ang_acc += abs(d.theta)
        self.prev_odom = odom
        if not self.particles:
            self._initialise(index, odom, scan, stamp)
            return True
        p = self.p
        due = (self.lin_acc >= p.linearUpdate or self.ang_acc >= p.angularUpdate
               or (p.temporalUpdate > 0 and stamp - self.last_stamp > p.temporalUpdate))
        if not due:
            if self.track_between:
                self._track(index, odom, scan)
            return False
        delta = self.last_odom.between(odom).as_array()
        prev = np.array([q.pose for q in self.particles])
        poses = self.motion.sample(prev, delta, self.rng)
        preds = compose_many(prev, delta)  # each particle's noiseless odometry prediction
        beams = prepare_beams(scan, p, self.laser)
        # search at least 3 sigma of the motion noise (a fast turn during a data gap needs it)
        sig = self.motion.sigmas(delta)
        window = (min(max(p.search_linear, 3 * float(np.hypot(sig[0], sig[1]))), 2.0),
                  min(max(p.search_angular, 3 * float(sig[2])), 1.0))
        grids = [q.grid for q in self.particles]
        ranges = [g.tile_range(*self._extent(pose, beams, window[0])) for g, pose in zip(grids, poses)]
        prior = self._priors(preds, sig)
        final, ll = np.empty_like(poses), np.empty(len(poses))
        for c in range(0, len(poses), CHUNK):  # bounded memory for many particles
            sl = slice(c, c + CHUNK)
            fs = self.fields.fieldset(grids[sl], ranges[sl], scratch=True)
            matched, score = self.matcher.match_many(fs, poses[sl], beams.match, window,
                                                     ScanMatcher.sub_prior(prior, sl))
            final[sl] = np.where((score >= p.minimumScore)[:, None], matched, poses[sl])
            ll[sl] = self.matcher.log_likelihoods(fs, final[sl], beams.match)
        for q, pose, w in zip(self.particles, final, ll.tolist()):
            q.pose = pose.copy()
            q.weight += w
            q.weight_sum += w
        self._resample_and_integrate(ranges, beams, index)
        self.last_odom, self.last_stamp, self.last_index = odom, stamp, index
        self.lin_acc = self.ang_acc = 0.0
        self.processed += 1
        return True

    # -- internals -------------------------------------------------------------------------
    def _track(self, index: int, odom: Pose2D, scan: LaserScan) -> None:
        """Match a skipped scan against the best particle's map, starting from odometry."""
        q = self.particles[self.best_index()]
        delta = self.last_odom.between(odom)
        pred = Pose2D(*map(float, q.pose)).compose(delta).as_array()
        beams = prepare_beams(scan, self.p, self.laser, free=False)
        if len(beams.match) < 10:
            return
        sig = self.motion.sigmas(delta.as_array())
        window = (min(max(self.p.search_linear, 3 * float(np.hypot(sig[0], sig[1]))), 2.0),
                  min(max(self.p.search_angular, 3 * float(sig[2])), 1.0))
        rng = q.grid.tile_range(*self._extent(pred, beams, window[0]))
        key = (self.processed, id(q.grid), rng)  # the maps change only when a scan is processed
        if self._track_field is None or self._track_field[0] != key:
            self._track_field = (key, self.fields.fieldset([q.grid], [rng]))
        fld = self._track_field[1]
        # no motion prior here: this offline refinement starts from the best particle's pose and
        # odometry, and a prior measurably hurt the intel benchmark (its odometry is poor)
        pose, score = self.matcher.match(fld, pred, beams.match, window)
        if score >= max(self.p.minimumScore, 0.3 * len(beams.match)):
            rel = Pose2D(*map(float, q.pose)).between(Pose2D(*map(float, pose)))
            self.between[index] = (self.last_index, rel.as_array())

    def _priors(self, preds: np.ndarray, sig: np.ndarray) -> MotionPrior | None:
        """Each particle's odometry prediction (P, 3) as a Gaussian prior: weight / variance, the
        variance being the motion model's for this increment plus a floor (exact odometry would pin
        the pose)."""
        p = self.p
        if p.prior_weight <= 0:
            return None
        var_t = float(sig[0] ** 2 + sig[1] ** 2) + p.prior_sigma_xy**2
        var_r = float(sig[2] ** 2) + p.prior_sigma_theta**2
        n = len(preds)
        return MotionPrior(preds, np.full(n, p.prior_weight / var_t), np.full(n, p.prior_weight / var_r))

    def _initialise(self, index: int, odom: Pose2D, scan: LaserScan, stamp: float) -> None:
        pose = odom.as_array()
        grid = TiledGrid(self.p.delta, halo=self.p.field_radius)
        beams = prepare_beams(scan, self.p, self.laser)
        integrate_into(grid, grid.tile_range(*self._extent(pose, beams)), pose, beams)
        node = TNode(pose.copy(), index, None)
        self.particles = [Particle(pose.copy(), grid.copy(), node=node) for _ in range(self.p.particles)]
        self.last_odom, self.last_stamp, self.last_index = odom, stamp, index
        self.lin_acc = self.ang_acc = 0.0
        self.processed += 1

    def _extent(self, pose: np.ndarray, beams: Beams, search: float | None = None) -> tuple[float, ...]:
        c, s = math.cos(pose[2]), math.sin(pose[2])
        e = np.vstack((beams.ends, beams.origin[None, :]))
        x = pose[0] + c * e[:, 0] - s * e[:, 1]
        y = pose[1] + s * e[:, 0] + c * e[:, 1]
        m = (search or self.p.search_linear) + (self.p.field_radius + 2) * self.p.delta + 0.5
        return x.min() - m, y.min() - m, x.max() + m, y.max() + m

    def _resample_and_integrate(self, ranges: list[tuple[int, int, int, int]], beams: Beams, index: int) -> None:
        gain = 1.0 / (self.p.ogain * len(self.particles))
        w = normalized_weights(np.array([q.weight for q in self.particles]), gain)
        self.last_neff = neff(w)
        if needs_resampling(w, self.p.resampleThreshold):
            self.resamples += 1
            keep = systematic_resample(w, self.rng)
            done: dict[int, Particle] = {}
            new: list[Particle] = []
            for k in keep.tolist():
                src = done.get(k)
                if src is None:  # first copy: integrate once, later copies share every tile
                    q = self.particles[k]
                    self._integrate_particle(q, ranges[k], beams, index)
                    q.weight = 0.0
                    done[k] = q
                    new.append(q)
                else:
                    new.append(Particle(src.pose.copy(), src.grid.copy(), 0.0, src.weight_sum, src.node))
            self.particles = new
        else:
            for q, rng in zip(self.particles, ranges):
                self._integrate_particle(q, rng, beams, index)

    def _integrate_particle(self, q: Particle, rng: tuple[int, int, int, int], beams: Beams, index: int) -> None:
        integrate_into(q.grid, rng, q.pose, beams)
        q.node = TNode(q.pose.copy(), index, q.node)

    # -- outputs ---------------------------------------------------------------------------
    def best_index(self) -> int:
        return int(np.argmax([q.weight_sum for q in self.particles]))

    def best_pose(self) -> Pose2D:
        return Pose2D(*map(float, self.particles[self.best_index()].pose))

    def map_to_odom(self) -> Pose2D:
        """The correction gmapping publishes: map ← odom = best pose ⊕ odom⁻¹ (at the last update)."""
        if self.last_odom is None:
            return Pose2D()
        return self.best_pose().compose(self.last_odom.inverse())

    def trajectory(self) -> list[tuple[int, Pose2D]]:
        """(scan index, pose) of every processed scan along the best particle's ancestry, oldest first."""
        out = []
        node = self.particles[self.best_index()].node if self.particles else None
        while node is not None:
            out.append((node.index, Pose2D(*map(float, node.pose))))
            node = node.parent
        return out[::-1]

    def occupancy_grid(self, stamp: float = 0.0, frame_id: str = "map") -> OccupancyGrid:
        p = self.p
        grid = self.particles[self.best_index()].grid if self.particles else TiledGrid(p.delta)
        return grid.to_occupancy_grid((p.xmin, p.ymin, p.xmax, p.ymax), stamp, frame_id)

    def memory_bytes(self) -> int:
        return unique_tile_bytes([q.grid for q in self.particles])
