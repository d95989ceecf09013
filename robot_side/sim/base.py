"""Simulated differential-drive base (Pioneer 3-AT; ``model: jackal`` for a Clearpath Jackal): cmd_vel with
limits, odometry with error, collisions.

Limits (MobileRobots P3-AT datasheet): top speed 0.7 m/s, rotation 140 deg/s (2.44 rad/s). Acceleration
limits default to the tutorial's DWAPlannerROS values (acc_lim_x 1.0 m/s^2, acc_lim_th 2.0 rad/s^2) so
the planner's model and the simulated robot agree.

Motion per step: each velocity moves toward its (clamped) command at most ``acc * dt``; the pose advances
along the exact arc of the step's mean velocities (exact for straight lines and constant-w arcs).

Odometry error (the gmapping terms; dρ, dθ the true translation and rotation of one step)::

    var_ρ = srr² |dρ| + srt² |dθ|        var_θ = str² |dρ| + stt² |dθ|
    dρ' = dρ + N(0, var_ρ)               dθ' = dθ + N(0, var_θ)

so after a single 1 m (1 rad) motion the error std is srr (srt) metres and str (stt) radians, and since
variances add, the error after a straight run of length L has std srr*sqrt(L) (independent of dt).
With ``gyro`` the heading's step comes from the base's gyro instead (ARIA's ArAnalogGyro, the P3-AT's optional
gyro, fused by ARCOS firmware into the pose the SIPs report; its noise figures are ARIA's own)::

    dθ' = (1 + gyro_scale_error) dθ + N(0, gyro_noise² dt + gyro_turn_noise² |dθ|)

Odometry integrates (dρ', dθ') from Pose2D(0, 0, 0) in the odom frame, or from Pose2D(0, 0, start yaw)
with ``odom_start_yaw_from_world`` (an odom frame with the world's axes at the start position, as a
Jackal's IMU-fused odometry: the BARN challenge sends its goal as (0, 10) in that frame); each step as a turn
about base_link, or about the point ``odom_rotation_center_x`` ahead of it (negative: behind;
``common.geometry.pivoted``). Only the odometry: the kinematic engine's robot itself turns about base_link.

Collision: if the footprint (sampled every <= res/2, inside and on the edge) at the next pose covers a
cell taller than ``min_obstacle_height``, ``contact`` records the mean contact point, ``collisions`` counts
a new collision if the previous blocked step is older than ``collision_debounce`` (a robot pushing on a
wall counts once), and the step happens only as far as it goes no deeper into obstacles (``penetration``):
the robot slides along a wall or backs away from it; into it, it stays and its velocity drops to zero.
"""

from __future__ import annotations

import math

import numpy as np

from common.geometry import Pose2D, distance_to_outline, normalize_angle, pivoted, points_in_polygon
from common.messages import Collision, Header, Odometry, Twist
from robot_side.sim.base_params import (
    BASE_PRESETS,
    JACKAL_FOOTPRINT,
    LX_FOOTPRINT,
    P3AT_FOOTPRINT,
    BaseParams,
    base_preset,
    load_base_params,
)
from robot_side.sim.world import World

__all__ = ["BaseParams", "CommandedBase", "DiffDriveBase", "P3AT_FOOTPRINT", "JACKAL_FOOTPRINT", "LX_FOOTPRINT",
           "BASE_PRESETS", "base_preset", "load_base_params"]

def _footprint_samples(poly: np.ndarray, step: float) -> np.ndarray:
    """Points inside and on the edge of a polygon, spaced at most ``step`` (robot frame)."""
    (xmin, ymin), (xmax, ymax) = poly.min(0), poly.max(0)
    xs = np.arange(xmin, xmax + step, step)
    ys = np.arange(ymin, ymax + step, step)
    gx, gy = np.meshgrid(np.minimum(xs, xmax), np.minimum(ys, ymax))
    pts = np.column_stack((gx.ravel(), gy.ravel()))
    inside = points_in_polygon(pts[:, 0], pts[:, 1], poly)
    edges = []
    for a, b in zip(poly, np.roll(poly, -1, axis=0)):
        n = max(2, math.ceil(np.linalg.norm(b - a) / step) + 1)
        edges.append(a + np.linspace(0.0, 1.0, n)[:, None] * (b - a))
    return np.vstack([pts[inside], *edges])


def _limit(v: float, target: float, acc: float, decel: float | None) -> float:
    """The rate limit that applies when going from v toward target: braking when the speed shrinks."""
    braking = abs(target) < abs(v) or target * v < 0
    return decel if braking and decel is not None else acc


def _toward(v: float, target: float, dv: float) -> tuple[float, float]:
    """New velocity and the mean velocity over a step that ramps v toward target by at most dv (dt = 1)."""
    if abs(target - v) <= dv:
        frac = abs(target - v) / dv if dv > 0 else 0.0  # fraction of the step spent ramping
        return target, frac * (v + target) / 2 + (1 - frac) * target
    nv = v + math.copysign(dv, target - v)
    return nv, (v + nv) / 2


LEAD_OUT = 0.005  # m at the outline: how far a blocked step's motion is followed to see whether it leads out


class CommandedBase:
    """What every simulated base shares (both engines): the latest cmd_vel with its timeout and limits,
    and the odometry / collision messages of its state (``odom``, ``v``, ``w``, ``collisions``, ``contact``)."""

    p: BaseParams
    odom: Pose2D
    v: float
    w: float
    collisions: int
    contact: tuple[float, float] | None
    cmd: tuple[float, float] = (0.0, 0.0)
    cmd_time: float = -math.inf

    def set_cmd_vel(self, twist: Twist, now: float) -> None:
        self.cmd = (float(twist.linear.x), float(twist.angular.z))
        self.cmd_time = now

    def commanded(self, now: float) -> tuple[float, float]:
        """(v, w) the base aims for at ``now``: the command clamped to the limits, zero after the timeout."""
        p = self.p
        tv, tw = self.cmd if now - self.cmd_time <= p.cmd_vel_timeout else (0.0, 0.0)
        return max(-p.max_vel_x, min(p.max_vel_x, tv)), max(-p.max_vel_theta, min(p.max_vel_theta, tw))

    def odometry(self, stamp: float) -> Odometry:
        # the twist stays (v, 0, w), as the wheels measure it, while the pose may move sideways
        # (odom_rotation_center_x): a consumer that predicts the pivot (DWA's rotation_center_x) adds it itself
        return Odometry(Header(stamp, self.p.odom_frame_id), self.p.base_frame_id, self.odom.to_transform(),
                        Twist.planar(self.v, self.w))

    def collision(self, stamp: float, frame_id: str = "map") -> Collision:
        x, y = self.contact if self.contact else (0.0, 0.0)
        return Collision(Header(stamp, frame_id), self.collisions, x, y)


class DiffDriveBase(CommandedBase):
    """Differential drive with ground truth pose (world frame) and noisy odometry (odom frame)."""

    def __init__(self, world: World, params: BaseParams | None = None, start: Pose2D | None = None):
        self.world = world
        self.p = params = params if params is not None else BaseParams()
        self.pose = start if start is not None else world.start  # ground truth in the world (map) frame
        self.odom = Pose2D(0.0, 0.0, self.pose.theta) if params.odom_start_yaw_from_world else Pose2D()
        self.v = self.w = 0.0  # actual velocities
        self.motors_enabled = params.motors_enabled
        self.collisions = 0
        self.contact: tuple[float, float] | None = None
        self.in_contact = False  # the last step was blocked
        self._last_contact_time = -math.inf
        self.rng = np.random.default_rng(params.seed)
        self.poly = np.asarray(params.footprint, float)
        self.samples = _footprint_samples(self.poly, world.resolution / 2)
        self.radius = float(np.hypot(self.poly[:, 0], self.poly[:, 1]).max())  # the outline's farthest point

    def set_motors(self, enabled: bool) -> None:
        self.motors_enabled = bool(enabled)
        if not enabled:
            self.v = self.w = 0.0

    def footprint_hits(self, pose: Pose2D) -> np.ndarray:
        """World points of the footprint samples that lie on an obstacle at ``pose``."""
        pts = pose.apply(self.samples)
        return pts[self.world.height_at(pts[:, 0], pts[:, 1]) > self.p.min_obstacle_height]

    def penetration(self, pose: Pose2D) -> float:
        """How deep (m) obstacle cells reach into the footprint at ``pose``: the deepest of the obstacle
        cells' corners inside the outline (its distance to the outline) and of the outline's vertices inside
        an obstacle cell (its distance to that cell's sides, one cell more where the neighbour across a side
        is an obstacle too). 0 when the outline only touches obstacles. Every overlap of a square cell and
        the outline holds one of the two, so this sees what the footprint samples miss between them.
        One figure for the whole outline: a robot already deep in one obstacle (a box dropped onto it) may
        go as deep into another."""
        res, (x0, y0) = self.world.resolution, self.world.origin
        outline = pose.apply(self.poly)
        (ix0, iy0), (ix1, iy1) = (np.floor((outline.min(0) - (x0, y0)) / res).astype(int),
                                  np.floor((outline.max(0) - (x0, y0)) / res).astype(int))
        rows, cols = self.world.shape
        ix0, iy0, ix1, iy1 = max(ix0, 0), max(iy0, 0), min(ix1, cols - 1), min(iy1, rows - 1)
        if ix0 > ix1 or iy0 > iy1:
            return 0.0
        iy, ix = np.nonzero(self.world.heights[iy0:iy1 + 1, ix0:ix1 + 1] > self.p.min_obstacle_height)
        if not len(ix):
            return 0.0
        ix, iy = ix + ix0, iy + iy0
        deepest = 0.0
        corners = np.column_stack([np.concatenate([x0 + (ix + a) * res for a in (0, 1, 0, 1)]),
                                   np.concatenate([y0 + (iy + b) * res for b in (0, 0, 1, 1)])])
        local = pose.inverse().apply(corners)
        inside = points_in_polygon(local[:, 0], local[:, 1], self.poly)
        if inside.any():
            deepest = float(distance_to_outline(local[inside], self.poly).max())
        cx, cy = self.world.cell_of(outline[:, 0], outline[:, 1])
        hit = self.world.height_at(outline[:, 0], outline[:, 1]) > self.p.min_obstacle_height
        if hit.any():
            px, py, cx, cy = outline[hit, 0], outline[hit, 1], cx[hit], cy[hit]
            fx, fy = px - (x0 + cx * res), py - (y0 + cy * res)  # the vertex within its cell, 0..res
            # to each side of its cell, one cell farther where the cell beyond is an obstacle too: a vertex
            # sliding along a wall keeps its depth as it crosses from one wall cell into the next
            h = self.world.height_at
            m = self.p.min_obstacle_height
            sides = [d + res * (h(px + dx, py + dy) > m) for d, dx, dy in
                     ((fx, -res, 0.0), (res - fx, res, 0.0), (fy, 0.0, -res), (res - fy, 0.0, res))]
            deepest = max(deepest, float(np.min(sides, axis=0).max()))
        return deepest

    def step(self, dt: float, now: float) -> None:
        """Advance ``dt`` seconds; ``now`` is the clock at the end of the step (for the cmd_vel timeout)."""
        p = self.p
        if dt <= 0:
            return
        if not self.motors_enabled:
            self.v = self.w = 0.0
            return
        tv, tw = self.commanded(now)
        nv, mv = _toward(self.v, tv, _limit(self.v, tv, p.acc_lim_x, p.decel_lim_x) * dt)
        nw, mw = _toward(self.w, tw, _limit(self.w, tw, p.acc_lim_th, p.decel_lim_th) * dt)
        d_rho, d_th = mv * dt, mw * dt
        new = self.pose.compose(_arc(d_rho, d_th))
        if d_rho != 0.0 or d_th != 0.0:
            hits = self.footprint_hits(new)
            if len(hits):
                self._touch(hits, now)
                # the obstacle stops what goes into it, not what leaves it or slides along it: the whole
                # step, its translation alone or its rotation alone happens if it ends no deeper in an
                # obstacle than now (``penetration``: 0 for a robot that only touches, more for a box dropped
                # onto it). Not the count of footprint samples on obstacles: a cell's corner poking between
                # two samples of the outline would catch one of them after any move, and pin the robot
                deep = self.penetration(self.pose)
                for dr, da, v, w in ((d_rho, d_th, nv, nw), (d_rho, 0.0, nv, 0.0), (0.0, d_th, 0.0, nw)):
                    moved = self.pose.compose(_arc(dr, da))
                    if (dr != 0.0 or da != 0.0) and (self.penetration(moved) <= deep + 1e-9
                                                     or self._leads_out(dr, da, deep)):
                        self.pose, self.v, self.w = moved, v, w
                        self._odometry(dr, da, dt)
                        return
                self.v = self.w = 0.0
                return
        self.in_contact = False
        self.pose, self.v, self.w = new, nv, nw
        self._odometry(d_rho, d_th, dt)

    def _leads_out(self, d_rho: float, d_th: float, deep: float) -> bool:
        """Does the same motion, carried on past the step by up to ``LEAD_OUT`` m at the outline, end no deeper
        than ``deep``?
        A corner hooked on a wall's corner leaves it by a path that first goes a little deeper (backing drags it
        across the wall's face before it clears the side): refusing every step that deepens at all pinned the
        robot for good, its speed ramping from zero in steps too small to get past (office02, the Kinect
        robot: every escape stalled at 0.00, 2026-12-01). A push into a wall never comes out: still refused."""
        reach = abs(d_rho) + abs(d_th) * self.radius
        if reach <= 0.0:
            return False
        return any(self.penetration(self.pose.compose(_arc(d_rho * k, d_th * k))) <= deep + 1e-9
                   for k in 1.0 + np.linspace(LEAD_OUT / reach / 4, LEAD_OUT / reach, 4))  # beyond the step

    def _touch(self, hits: np.ndarray, now: float) -> None:
        """A blocked step: a new collision unless the last contact is recent; where it touches."""
        if now - self._last_contact_time > self.p.collision_debounce:
            self.collisions += 1
        self.contact = (float(hits[:, 0].mean()), float(hits[:, 1].mean()))
        self._last_contact_time = now
        self.in_contact = True

    def _odometry(self, d_rho: float, d_th: float, dt: float) -> None:
        p = self.p
        a, b = abs(d_rho), abs(d_th)
        var_r = p.srr ** 2 * a + p.srt ** 2 * b
        if p.gyro:
            var_t = (p.gyro_noise ** 2 * dt if a or b else 0.0) + p.gyro_turn_noise ** 2 * b
            d_th *= 1.0 + p.gyro_scale_error
        else:
            var_t = p.str ** 2 * a + p.stt ** 2 * b
        if var_r > 0 or var_t > 0:
            e = self.rng.standard_normal(2)
            d_rho += math.sqrt(var_r) * e[0]
            d_th += math.sqrt(var_t) * e[1]
        self.odom = self.odom.compose(pivoted(_arc(d_rho, d_th), p.odom_rotation_center_x))



def _arc(d_rho: float, d_th: float) -> Pose2D:
    """Relative pose after moving d_rho along an arc that turns d_th."""
    if abs(d_th) < 1e-9:
        return Pose2D(d_rho, 0.0, d_th)
    r = d_rho / d_th
    return Pose2D(r * math.sin(d_th), r * (1 - math.cos(d_th)), normalize_angle(d_th))
