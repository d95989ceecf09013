"""The footprint obstacle cost (base_local_planner's ObstacleCostFunction / footprintCost).

``score`` rasterises the footprint outline at every pose that could touch a non-free cell;
``lower_bound`` only reads the cells under the trajectory's centre points (the largest of them bounds
the score from below, a centre on an INSCRIBED, LETHAL, unknown or off-map cell rejects), so the planner
rasterises the outline for the few trajectories that could still win.
"""

from __future__ import annotations

import math
import zlib

import numpy as np
from scipy import ndimage

from common.geometry import footprint_radii
from common.jit import kernel
from master_side.planning.grid import INSCRIBED, LETHAL
from master_side.planning.local.cost_base import REJECT, CostFunction
from master_side.planning.local.scoring_context import ScoringContext, footprint_outline
from master_side.planning.local.traj_cells import BIG, kernel_inside, max_cell_values, point_cells, steps_xy
from master_side.planning.local.trajectories import Trajectories


class ObstacleCost(CostFunction):
    """Max costmap cost under the footprint along each trajectory; rejects LETHAL / unknown / off-map.

    Like base_local_planner's footprintCost: the centre cell must be below INSCRIBED, the footprint
    outline must not touch a LETHAL or NO_INFORMATION cell. The outline is only rasterised for poses
    within reach of a non-free cell; elsewhere every footprint cell is FREE and the centre cost is
    exact. Reach is judged by the chessboard distance to the nearest lethal cell, a lower bound of the
    Euclidean one (so no pose that could touch is skipped) that is five times cheaper to compute.
    """

    name = "ObstacleCost"

    def __init__(self, scale: float = 1.0):
        super().__init__(scale)
        self._key: tuple | None = None

    def prepare(self, ctx: ScoringContext) -> bool:
        super().prepare(ctx)
        g = ctx.grid
        key = (g.shape, zlib.crc32(np.ascontiguousarray(g).data), float(ctx.resolution), ctx.footprint.tobytes())
        if key == self._key:  # the same costmap as the last call (several checks in one cycle)
            return True
        blocked = g >= LETHAL
        self.clear = (
            ndimage.distance_transform_cdt(~blocked, metric="chessboard") * ctx.resolution
            if blocked.any()
            else np.full(g.shape, np.inf)
        )
        soft = (g > 0) & (g < LETHAL)
        # the farthest an inflated cell lies from a lethal one (Euclidean <= sqrt(2) x chessboard)
        self.extent = (
            math.sqrt(2.0) * float(self.clear[soft].max()) if soft.any() and blocked.any()
            else (np.inf if soft.any() else 0.0)
        )
        self.inscribed, self.circumscribed = footprint_radii(ctx.footprint)
        self.outline = footprint_outline(ctx.footprint, ctx.resolution)
        self._key = key
        return True

    def score(self, trajs: Trajectories) -> np.ndarray:
        ctx = self.ctx
        s, t = trajs.poses.shape[:2]
        pts = trajs.poses.reshape(-1, 3)
        r, c, inside = ctx.cells(pts[:, :2])
        centre = ctx.grid[r, c].astype(np.int64)
        clear = self.clear[r, c]
        res = ctx.resolution
        bad = ~inside | (centre >= INSCRIBED)
        cost = centre.astype(float)
        # A pose equal to the previous one of its trajectory (padding after a short trajectory, a robot
        # standing still) has the same outline: rasterise it once.
        w = ctx.grid.shape[1]
        same = np.zeros((s, t), bool)
        poses = trajs.poses
        same[:, 1:] = (poses[:, 1:] == poses[:, :-1]).all(axis=2)
        first = ~same
        src = np.maximum.accumulate(np.where(first, np.arange(t)[None, :], 0), axis=1)
        src = (src + (np.arange(s) * t)[:, None]).ravel()
        first_flat = first.ravel()
        # outline cells can be LETHAL only within the circumscribed radius; they can cost > 0 within
        # circumscribed + inflation extent. Check the first band, drop rejected trajectories, then the second.
        band = self.circumscribed + 1.5 * res  # cell-centre distances: allow for the discretisation
        flat = ctx.grid.ravel()
        outline_bad = np.zeros(s * t, bool)
        outline_cost = np.zeros(s * t)
        # the cost-only band samples every other outline point (about 2 cells apart): cheaper, and
        # the inflation cost changes little over one cell
        for lo, hi, outline in ((-np.inf, band, self.outline), (band, band + self.extent, self.outline[::2])):
            dead = np.repeat(bad.reshape(s, t).any(axis=1), t)
            near = np.flatnonzero(first_flat & ~dead & (clear <= hi) & (clear > lo))
            if near.size == 0:
                continue
            p = pts[near]
            cs, sn = np.cos(p[:, 2])[:, None], np.sin(p[:, 2])[:, None]
            ox, oy = outline[:, 0][None, :], outline[:, 1][None, :]
            orr, occ, oin = ctx.cells_xy(p[:, 0:1] + cs * ox - sn * oy, p[:, 1:2] + sn * ox + cs * oy)
            oc = flat[orr * w + occ]
            outline_bad[near] = (~oin | (oc >= LETHAL)).any(axis=1)
            outline_cost[near] = oc.max(axis=1)
            bad |= outline_bad[src]
        bad |= outline_bad[src]
        cost = np.maximum(cost, outline_cost[src])
        bad = bad.reshape(s, t)
        if t > 1 and bad[:, 0].any():
            _allow_escape(bad, clear.reshape(s, t))
        bad_t = bad.any(axis=1)
        out = cost.reshape(s, t).max(axis=1)
        out[bad_t] = REJECT
        return out

    def lower_bound(self, trajs: Trajectories) -> np.ndarray | None:
        """Largest centre-cell cost per trajectory, REJECT where a centre cell alone rejects it; None
        when the start pose is already in contact (``score``'s escape rule then applies)."""
        ctx = self.ctx
        flat, inside = point_cells(trajs, ctx, 0.0)
        if flat.size == 0:
            return None
        out, start_bad = max_cell_values(ctx.grid.ravel(), flat, inside, INSCRIBED, REJECT)
        if start_bad or not self._start_free(trajs):
            return None
        return out

    def pose_scores(self, trajs: Trajectories, steps: np.ndarray, rows: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
        """(cost, bad) of the poses ``trajs.poses[rows, steps]`` of a set whose ``lower_bound`` was not
        None, as ``score`` sees them (no escape rule from a free start): the outline is rasterised
        where a non-free cell is within reach, the full outline in the lethal band, every other point
        beyond; a trajectory's score is its poses' max cost, or REJECT if any pose is bad."""
        ctx = self.ctx
        flat, inside = point_cells(trajs, ctx, 0.0)  # (T + 1, S)
        x, y, _, c, sn = steps_xy(trajs)
        band = self.circumscribed + 1.5 * ctx.resolution
        h, w = ctx.grid.shape
        return _outline_scores(
            ctx.grid.ravel(), self.clear.ravel(), flat, *kernel_inside(inside), x, y, c, sn,
            np.asarray(steps, np.intp), np.asarray(rows, np.intp), self.outline,
            band, band + self.extent, float(ctx.origin[0]), float(ctx.origin[1]), 1.0 / ctx.resolution, h, w,
            INSCRIBED, LETHAL)

    def probe_steps(self, trajs: Trajectories, rows: np.ndarray) -> np.ndarray:
        """Per trajectory, the pose nearest to a lethal cell (its max cost is usually there)."""
        flat = point_cells(trajs, self.ctx, 0.0)[0][:, rows]
        return np.argmin(self.clear.ravel()[flat], axis=0)

    def _start_free(self, trajs: Trajectories) -> bool:
        """The start pose (shared by all trajectories) is valid, outline included."""
        ctx, p0 = self.ctx, trajs.row(0)[0]
        r, c, _ = ctx.cells(p0[:2])
        reach = self.circumscribed + 2.0 * ctx.resolution
        lo, hi = ctx.origin + reach, ctx.origin + np.array(ctx.grid.shape[::-1]) * ctx.resolution - reach
        if self.clear[r, c] > self.circumscribed + 1.5 * ctx.resolution and (lo <= p0[:2]).all() \
                and (p0[:2] <= hi).all():
            return True  # no lethal, unknown or off-map cell within the outline's reach
        return bool(self.score(Trajectories(trajs.poses[:1, :1], trajs.vels[:1]))[0] >= 0)


def _allow_escape(bad: np.ndarray, clear: np.ndarray) -> None:
    """The robot already touches an obstacle (the padded footprint at its current pose, shared by every
    trajectory): rejecting every move would wedge it. Accept a trajectory whose leading in-contact
    poses never get closer to the nearest obstacle and which leaves contact within half its length;
    moves that stay in contact or push on are still rejected. ``bad`` (S, T) is edited in place."""
    lead = np.logical_and.accumulate(bad, axis=1)
    n_lead = lead.sum(axis=1)
    steps = np.diff(clear, axis=1)
    closer = np.concatenate((np.zeros((len(bad), 1), bool), steps < -1e-9), axis=1) & lead
    ok = (n_lead < bad.shape[1] / 2) & ~closer.any(axis=1)
    bad[ok[:, None] & lead] = False


@kernel
def _outline_scores(g, clear, flat, inside, has_inside, x, y, c, sn, steps, rows, outline, band, far, ox, oy,
                    inv, h, w, inscribed, lethal):
    """``pose_scores``, one pose at a time: the centre cell, then every outline point where the nearest
    lethal cell is within ``band`` (every other point within ``far``), with ``flat_cells``' cell
    arithmetic; an outline point off the map reads cell 0 and is bad."""
    m = steps.size
    cost = np.empty(m)
    bad = np.empty(m, np.bool_)
    for i in range(m):
        st, ro = steps[i], rows[i]
        f = flat[st, ro]
        cv = g[f]
        b = cv >= inscribed or (has_inside and not inside[st, ro])
        cst = float(cv)
        cl = clear[f]
        stride = 1 if cl <= band else (2 if cl <= far else 0)
        if stride:
            px, py, cs, ss = x[st, ro], y[st, ro], c[st, ro], sn[st, ro]
            top = g[0]
            first = True
            for o in range(0, outline.shape[0], stride):
                qx, qy = outline[o, 0], outline[o, 1]
                cx = np.int32(((px + cs * qx - ss * qy) - ox) * inv + BIG) - BIG
                cy = np.int32(((py + ss * qx + cs * qy) - oy) * inv + BIG) - BIG
                if 0 <= cx < w and 0 <= cy < h:
                    v = g[cy * w + cx]
                else:
                    v = g[0]
                    b = True
                if v >= lethal:
                    b = True
                if first or v > top:
                    top, first = v, False
            cst = max(cst, float(top))
        cost[i] = cst
        bad[i] = b
    return cost, bad
