"""AMCL: adaptive Monte Carlo localisation on a known map (pure; ROS amcl's behaviour and names).

Per scan (``Amcl.update(odom, scan)``): once the odometry has moved more than ``update_min_d`` (x or
y) or ``update_min_a`` since the last filter update (or after an initial / global pose), every
particle is moved by the odometry increment (``diff`` motion model), weighted by the likelihood field
of the scan, and every ``resample_interval`` updates the set is resampled with a KLD-adaptive size;
with ``recovery_alpha_slow`` < ``recovery_alpha_fast`` a share ``1 - w_fast / w_slow`` of the draws
are uniformly random free-space poses. The estimate is the mean and covariance of the heaviest
cluster; ``map_to_odom()`` = estimate ⊕ odom⁻¹ at the scan used for it.

With ``refine_pose`` (zenav), every scan also refines the estimate by a local search of that scan's joint
likelihood (``refine.py``), starting from the filter's mean at a filter update and, in between, from
the pose refined at that update carried by the odometry (never from the last scan's result, so scans
between updates cannot walk the estimate away from the filter's). At a filter update, once the
estimate's cluster has converged (``_within_reach``), its particles are shifted by the correction
(position by the translation, heading by the turn), so the cloud follows; other clusters (other
hypotheses) stay where they are, and a wide cloud converges by the filter alone (shifted by corrections
found near a wrong mean, a 0.5 m initial cloud was dragged off the truth on intel).

Deviations from ROS amcl (documented choices): the average weight fed to the slow / fast filters is
the weighted mean likelihood (ROS divides the total by the particle count, which makes recovery react
to KLD changing the count); a set occupying a single KLD bin shrinks to ``min_particles`` (ROS keeps
``max_particles``); draws are systematic (low variance) rather than independent.
"""

from __future__ import annotations

import math

import numpy as np

from common.geometry import Pose2D, normalize_angle, normalize_angles
from common.messages import LaserScan, OccupancyGrid
from master_side.localization.likelihood_field import LikelihoodField, beam_likelihoods, select_beams
from master_side.localization.motion_model import DiffMotionModel, OmniMotionModel
from master_side.localization.params import AmclParams
from master_side.localization.refine import REACH_M, REACH_RAD, PoseRefiner
from master_side.localization.sampling import best_cluster_estimate, heaviest_cluster, kld_resample, weighted_stats

SHIFT_REACHES = 2.0  # refine_pose shifts a cluster whose deviations are within this many search reaches


class Amcl:
    """The filter. Not thread-safe: one caller (the node's scan thread) at a time."""

    def __init__(self, params: AmclParams, grid: OccupancyGrid, laser: Pose2D | None = None,
                 rng: np.random.Generator | None = None) -> None:
        p = self.p = params
        self.rng = rng or np.random.default_rng(p.seed or None)
        self.grid = grid
        self.field = LikelihoodField(grid, p.laser_likelihood_max_dist, p.laser_penalize_interior)
        self._free = self.field.free_cell_centres()
        if len(self._free) == 0:
            raise ValueError("the map has no free cell")
        self.laser = laser or Pose2D()
        corrected = p.odom_model_type.endswith("-corrected")
        self.motion: DiffMotionModel | OmniMotionModel = (
            OmniMotionModel(p.odom_alpha1, p.odom_alpha2, p.odom_alpha3, p.odom_alpha4, p.odom_alpha5, corrected)
            if p.odom_model_type.startswith("omni") else
            DiffMotionModel(p.odom_alpha1, p.odom_alpha2, p.odom_alpha3, p.odom_alpha4, corrected=corrected))
        self.updates = 0  # filter (sensor) updates done
        self.sideways_increments = 0  # diff model only: odometry increments it cannot represent (_sideways)
        self._refiner: tuple[float, PoseRefiner] | None = None  # (range cap, its table), refine_pose only
        self.w_slow = self.w_fast = 0.0
        self.init_pose(Pose2D(p.initial_pose_x, p.initial_pose_y, p.initial_pose_a),
                       (p.initial_cov_xx, p.initial_cov_yy, p.initial_cov_aa))

    # -- (re)initialisation --------------------------------------------------------------------------
    def init_pose(self, mean: Pose2D, cov: tuple[float, float, float]) -> None:
        """``max_particles`` Gaussian particles around ``mean`` (variances xx, yy, aa); the next scan
        updates the filter without waiting for motion (ROS: initialpose / initial_pose_*)."""
        n = self.p.max_particles
        sd = np.sqrt(np.maximum(np.asarray(cov, float), 0.0))
        self.poses = np.asarray(mean.as_array()) + self.rng.standard_normal((n, 3)) * sd
        self.poses[:, 2] = normalize_angles(self.poses[:, 2])
        self._reset(mean, np.diag(np.asarray(cov, float)))

    def global_localization(self) -> None:
        """``max_particles`` poses uniform over the free cells (ROS's global_localization service)."""
        self.poses = self.random_poses(self.p.max_particles)
        mean, cov, _ = best_cluster_estimate(self.poses, np.ones(len(self.poses)))
        self._reset(mean, cov)

    def _reset(self, mean: Pose2D, cov: np.ndarray) -> None:
        self.weights = np.full(len(self.poses), 1.0 / len(self.poses))
        self.last_odom: Pose2D | None = None  # next scan: update without motion
        self.resample_count = 0
        self.w_slow = self.w_fast = 0.0
        self.mean, self.cov = mean, cov
        self.odom_at_mean: Pose2D | None = None
        self._at_update: Pose2D | None = None  # map -> odom at the last filter update (refine_pose's anchor)

    def random_poses(self, n: int) -> np.ndarray:
        """``n`` poses uniform over the known-free cells, uniform yaw."""
        res = self.field.resolution
        cells = self._free[self.rng.integers(0, len(self._free), n)]
        xy = cells + self.rng.uniform(-res / 2, res / 2, (n, 2))
        return np.column_stack((xy, self.rng.uniform(-np.pi, np.pi, n)))

    # -- the update ----------------------------------------------------------------------------------
    def needs_update(self, odom: Pose2D) -> bool:
        """True when the next scan would update the filter (first scan, or moved enough)."""
        if self.last_odom is None:
            return True
        return (abs(odom.x - self.last_odom.x) > self.p.update_min_d
                or abs(odom.y - self.last_odom.y) > self.p.update_min_d
                or abs(normalize_angle(odom.theta - self.last_odom.theta)) > self.p.update_min_a)

    def _sideways(self, old: Pose2D, new: Pose2D) -> bool:
        """True for an increment the ``diff`` model misreads: base_link moved (over 1 cm) more than 45 deg off
        its mean heading. A differential drive moves along an arc, whose chord lies on the mean heading; a base
        that turns about a point off base_link (a skid-steered base whose odometry says so, robot_side's
        ``odom_rotation_center_x``) or an omni base moves sideways, which ``diff`` reads as a turn, a drive and
        a turn back, with both turns' noise. The omni models take it as it is. An increment that turns more than
        90 deg (scans dropped, a large ``update_min_a``) may be a drive and a turn in either order: not judged."""
        if self.p.odom_model_type.startswith("omni"):
            return False
        dx, dy, turn = new.x - old.x, new.y - old.y, normalize_angle(new.theta - old.theta)
        if math.hypot(dx, dy) < 0.01 or abs(turn) > math.pi / 2:
            return False
        off = abs(normalize_angle(math.atan2(dy, dx) - old.theta - turn / 2))
        return math.pi / 4 < off < 3 * math.pi / 4

    def update(self, odom: Pose2D, scan: LaserScan, laser: Pose2D | None = None) -> bool:
        """One scan with the odometry pose (odom → base) at its time. Returns True if the filter ran
        (with ``refine_pose`` the estimate may have changed either way)."""
        if laser is not None:
            self.laser = laser
        if not self.needs_update(odom):
            if self.p.refine_pose and self._at_update is not None:
                self._refine(self._at_update.compose(odom), odom, scan)
            return False
        if self.last_odom is not None:
            self.sideways_increments += self._sideways(self.last_odom, odom)
            self.poses = self.motion.sample(self.poses, self.last_odom, odom, self.rng)
        self.last_odom = odom
        self._sensor_update(scan)
        self.resample_count += 1
        if self.resample_count % self.p.resample_interval == 0:
            self._resample()
        best, _ = heaviest_cluster(self.poses, self.weights)
        self.mean, self.cov = weighted_stats(self.poses[best], self.weights[best])
        self.odom_at_mean = odom
        if self.p.refine_pose:
            self._refine(self.mean, odom, scan, shift=best if self._within_reach() else None)
            self._at_update = self.map_to_odom()
        self.updates += 1
        return True

    def _within_reach(self) -> bool:
        """The estimate's cluster has converged enough for the refined pose to correct it as a whole: its
        standard deviations (x, y, yaw) within SHIFT_REACHES times the search's reach. The spread a user's
        initial pose gets (0.5 m, 15 deg) is not; a tracking cloud on intel (median 0.08 m, p90 0.15 m) is."""
        sd = np.sqrt(np.maximum(np.diag(self.cov), 0.0))
        k = SHIFT_REACHES
        return bool(sd[0] <= k * REACH_M and sd[1] <= k * REACH_M and sd[2] <= k * REACH_RAD)

    def _refine(self, start: Pose2D, odom: Pose2D, scan: LaserScan, shift: np.ndarray | None = None) -> None:
        """The estimate becomes the likeliest pose for this scan near ``start``; the particles in ``shift``
        (a mask: the cluster the estimate came from) move by the same correction."""
        p = self.p
        lo, hi = self._scan_limits(scan)
        ranges, angles = select_beams(scan.ranges, scan.angles(), p.refine_max_beams, lo, hi)
        if self._refiner is None or self._refiner[0] != hi:  # the table depends on the range cap
            self._refiner = (hi, PoseRefiner(self.grid, p.laser_likelihood_max_dist, p.laser_penalize_interior,
                                             p.laser_z_hit, p.laser_z_rand, p.laser_sigma_hit, hi))
        pose = self._refiner[1].refine(start, self.laser, ranges, angles)
        if shift is not None:
            d = pose.as_array() - np.asarray(start.as_array())
            moved = self.poses[shift] + (d[0], d[1], normalize_angle(float(d[2])))
            moved[:, 2] = normalize_angles(moved[:, 2])
            self.poses[shift] = moved
        self.mean, self.odom_at_mean = pose, odom

    def _scan_limits(self, scan: LaserScan) -> tuple[float, float]:
        lo = self.p.laser_min_range if self.p.laser_min_range >= 0 else scan.range_min
        hi = self.p.laser_max_range if self.p.laser_max_range > 0 else scan.range_max
        return lo, hi

    def _sensor_update(self, scan: LaserScan) -> None:
        p = self.p
        lo, hi = self._scan_limits(scan)
        ranges, angles = select_beams(scan.ranges, scan.angles(), p.laser_max_beams, lo, hi)
        like = beam_likelihoods(self.field, self.poses, self.laser, ranges, angles, p.laser_z_hit,
                                p.laser_z_rand, p.laser_sigma_hit, hi,
                                product=p.laser_model_type == "likelihood_field_prob")
        w = self.weights * like
        total = float(w.sum())
        if not math.isfinite(total) or total <= 0.0:
            self.weights = np.full(len(self.poses), 1.0 / len(self.poses))
            return
        self.weights = w / total
        w_avg = total  # previous weights sum to one: the weighted mean likelihood
        slow, fast = self.w_slow, self.w_fast
        self.w_slow = w_avg if slow == 0.0 else slow + p.recovery_alpha_slow * (w_avg - slow)
        self.w_fast = w_avg if fast == 0.0 else fast + p.recovery_alpha_fast * (w_avg - fast)

    def random_fraction(self) -> float:
        """Share of random particles the next resampling injects (0 when recovery is off)."""
        if self.p.recovery_alpha_slow <= 0.0 or self.p.recovery_alpha_fast <= 0.0 or self.w_slow <= 0.0:
            return 0.0
        return max(0.0, 1.0 - self.w_fast / self.w_slow)

    def _resample(self) -> None:
        p = self.p
        frac = self.random_fraction()
        self.poses = kld_resample(self.poses, self.weights, p.min_particles, p.max_particles, p.kld_err,
                                  p.kld_z, self.rng, frac, self.random_poses)
        self.weights = np.full(len(self.poses), 1.0 / len(self.poses))
        if frac > 0.0:  # as ROS: restart the averages after an injection
            self.w_slow = self.w_fast = 0.0

    # -- output --------------------------------------------------------------------------------------
    def estimate(self) -> tuple[Pose2D, np.ndarray]:
        """Mean pose (map → base) and its 3×3 covariance (x, y, yaw)."""
        return self.mean, self.cov

    def map_to_odom(self) -> Pose2D | None:
        """map → odom = estimate ⊕ (odom → base)⁻¹ at the last update; None before the first update."""
        if self.odom_at_mean is None:
            return None
        return self.mean.compose(self.odom_at_mean.inverse())
