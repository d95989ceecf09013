"""Velocity sampling in the dynamic window and vectorised forward simulation of all samples."""

from __future__ import annotations

import math

import numpy as np

from common.jit import kernel


class Trajectories:
    """S simulated trajectories: ``poses`` (S, T, 3) with row 0 the start pose, ``vels`` (S, 3) samples.

    ``cache`` holds per-set derived arrays (cells of the poses, ...) shared by the cost functions of one
    cycle. A set simulated at constant velocities keeps its poses in the cache's step-major arrays and
    builds the (S, T, 3) array only when something asks for it (the scoring does not)."""

    __slots__ = ("_poses", "vels", "cache", "_layout")

    def __init__(self, poses: np.ndarray | None, vels: np.ndarray, cache: dict | None = None,
                 layout: tuple | None = None):
        self._poses, self.vels = poses, vels
        self.cache = {} if cache is None else cache
        self._layout = layout  # (x, y, th, inv): (T, S), (T, S), (T, W) headings per distinct w, (S,)

    @property
    def poses(self) -> np.ndarray:
        if self._poses is None:
            x, y, th, inv = self._layout
            poses = np.empty((x.shape[1], x.shape[0], 3))
            poses[:, :, 0], poses[:, :, 1], poses[:, :, 2] = x.T, y.T, th[:, inv].T
            self._poses = poses
        return self._poses

    @property
    def n_poses(self) -> int:
        """Poses per trajectory (T)."""
        return int(self._poses.shape[1] if self._poses is not None else self._layout[0].shape[0])

    def row(self, i: int) -> np.ndarray:
        """(T, 3) poses of trajectory ``i`` (without building every trajectory's)."""
        if self._poses is not None:
            return self._poses[i]
        x, y, th, inv = self._layout
        return np.column_stack((x[:, i], y[:, i], th[:, inv[i]]))

    def __len__(self) -> int:
        return int(self.vels.shape[0])

    def subset(self, idx: np.ndarray) -> Trajectories:
        return Trajectories(self.poses[idx], self.vels[idx])


def linspace_window(lo: float, hi: float, n: int) -> np.ndarray:
    """n samples from lo to hi inclusive (one sample: hi if lo == hi else the middle); always includes 0
    when 0 lies inside the window so 'stop' and 'pure rotation' are candidates."""
    if hi < lo:
        return np.zeros(0)
    if n <= 1 or hi - lo < 1e-9:
        v = np.array([0.0 if lo <= 0.0 <= hi else 0.5 * (lo + hi)])
        return v
    v = np.linspace(lo, hi, n)
    if lo < 0.0 < hi and not np.any(np.abs(v) < 1e-9):
        v[np.argmin(np.abs(v))] = 0.0
    return v


def sample_grid(vx: np.ndarray, vy: np.ndarray, vth: np.ndarray) -> np.ndarray:
    """Cartesian product of per-axis samples -> (S, 3)."""
    vx, vy, vth = (np.asarray(v, dtype=float).ravel() for v in (vx, vy, vth))
    out = np.empty((len(vx), len(vy), len(vth), 3))  # vx slowest, vth fastest (meshgrid "ij")
    out[..., 0] = vx[:, None, None]
    out[..., 1] = vy[None, :, None]
    out[..., 2] = vth[None, None, :]
    return out.reshape(-1, 3)


def simulate(
    start: np.ndarray,
    vel0: np.ndarray,
    samples: np.ndarray,
    sim_time: float,
    steps: int,
    acc: np.ndarray | None = None,
) -> Trajectories:
    """Forward-simulate (S, 3) velocity samples (robot frame vx, vy, w) from pose ``start`` (3,).

    ``acc`` None: each sample is held constant for sim_time (DWA). Otherwise the velocity ramps from
    ``vel0`` toward the sample at the (3,) acceleration limits (trajectory rollout). Euler steps with the
    heading at the start of each step, like base_local_planner.
    """
    samples = np.asarray(samples, dtype=float).reshape(-1, 3)
    t = max(int(steps), 1)
    dt = sim_time / t
    if acc is None:
        return _integrate_constant(start, samples, t, dt)
    k = np.arange(1, t + 1)[None, :, None] * dt
    lo = np.asarray(vel0, float)[None, None, :] - np.asarray(acc, float)[None, None, :] * k
    hi = np.asarray(vel0, float)[None, None, :] + np.asarray(acc, float)[None, None, :] * k
    v = np.clip(samples[:, None, :], lo, hi)
    return Trajectories(_integrate(start, v, dt), samples)


def _integrate(start: np.ndarray, v: np.ndarray, dt) -> np.ndarray:
    """Poses (S, T + 1, 3) from ``start`` under robot-frame velocities ``v`` (S, T, 3) held ``dt`` (scalar
    or (S, 1)) each: Euler steps with the heading at the start of each step, like base_local_planner."""
    s, t = v.shape[:2]
    th = np.empty((s, t + 1))
    th[:, 0] = start[2]
    np.cumsum(v[:, :, 2] * dt, axis=1, out=th[:, 1:])
    th[:, 1:] += start[2]
    c, sn = np.cos(th[:, :-1]), np.sin(th[:, :-1])
    poses = np.empty((s, t + 1, 3))
    poses[:, 0, 0], poses[:, 0, 1] = start[0], start[1]
    np.cumsum((v[:, :, 0] * c - v[:, :, 1] * sn) * dt, axis=1, out=poses[:, 1:, 0])
    np.cumsum((v[:, :, 0] * sn + v[:, :, 1] * c) * dt, axis=1, out=poses[:, 1:, 1])
    poses[:, 1:, 0] += start[0]
    poses[:, 1:, 1] += start[1]
    poses[:, :, 2] = th
    return poses


def _integrate_constant(start: np.ndarray, samples: np.ndarray, t: int, dt: float) -> Trajectories:
    """``_integrate`` for samples held constant over all ``t`` steps, with the same arithmetic (so the
    same bits): headings, their cosines and sines once per distinct rotation speed, the running sums in
    a (step, sample) layout. The (T + 1, S) x, y, cos and sin arrays go to the cache ("xyT"); the
    (S, T + 1, 3) poses are built on first use."""
    s = samples.shape[0]
    if s == 0:
        return Trajectories(np.empty((s, t + 1, 3)), samples)
    w, inv = np.unique(samples[:, 2], return_inverse=True)
    th = np.empty((len(w), t + 1))
    th[:, 0] = start[2]
    np.cumsum(np.repeat((w * dt)[:, None], t, axis=1), axis=1, out=th[:, 1:])
    th[:, 1:] += start[2]
    cos_t, sin_t, x, y = _rollout(np.cos(th), np.sin(th), inv, np.ascontiguousarray(samples[:, 0]),
                                  np.ascontiguousarray(samples[:, 1]), bool(samples[:, 1].any()), float(dt),
                                  float(start[0]), float(start[1]))
    out = Trajectories(None, samples, layout=(x, y, th.T, inv))
    out.cache["xyT"] = (x, y, None, cos_t, sin_t)  # headings: see Trajectories.row / poses
    return out


def ros_steps(samples: np.ndarray, sim_time: float, sim_granularity: float, angular_granularity: float,
              fixed: bool = False) -> np.ndarray:
    """Per-sample step counts as base_local_planner's TrajectoryPlanner computes them: the larger of
    |v| * sim_time / sim_granularity and |w| / angular_sim_granularity (ROS does not multiply the
    angular term by sim_time), rounded, at least 1; ``fixed`` (heading scoring): sim_time / granularity."""
    samples = np.asarray(samples, dtype=float).reshape(-1, 3)
    if fixed:
        n = np.full(len(samples), int(sim_time / sim_granularity + 0.5))
    else:
        vmag = np.hypot(samples[:, 0], samples[:, 1])
        n = (np.maximum(vmag * sim_time / sim_granularity, np.abs(samples[:, 2]) / angular_granularity)
             + 0.5).astype(int)
    return np.maximum(n, 1)


def simulate_ramped(start: np.ndarray, vel0: np.ndarray, samples: np.ndarray, sim_time: float,
                    steps: np.ndarray, acc: np.ndarray) -> tuple[Trajectories, np.ndarray]:
    """TrajectoryPlanner::generateTrajectory for all samples at once.

    Sample i takes ``steps[i]`` points ``dt_i = sim_time / steps[i]`` apart, the first at ``start``; the
    velocity ramps from ``vel0`` toward the sample at ``acc`` per second before each step, and the
    position advances with the heading of the previous point. Rows are padded with their last point up
    to the longest sample. Returns (trajectories, steps).
    """
    samples = np.asarray(samples, dtype=float).reshape(-1, 3)
    steps = np.asarray(steps, dtype=int).reshape(-1)
    s, t = samples.shape[0], int(steps.max(initial=1))
    dt = (sim_time / steps)[:, None]
    k = np.arange(1, t)[None, :]
    live = (k < steps[:, None]).astype(float)  # step k exists (points 0..steps-1)
    v = np.empty((s, max(t - 1, 0), 3))
    for a in range(3):
        reach = acc[a] * k * dt
        v[:, :, a] = np.clip(samples[:, a:a + 1], vel0[a] - reach, vel0[a] + reach)
    v *= live[:, :, None]
    return Trajectories(_integrate(start, v, dt), samples), steps


def num_steps(
    samples: np.ndarray, sim_time: float, sim_granularity: float, angular_granularity: float
) -> int:
    """Steps so the fastest sample moves at most sim_granularity (m) / angular_granularity (rad) per step."""
    if samples.size == 0:
        return 1
    trans = float(np.max(np.hypot(samples[:, 0], samples[:, 1]))) * sim_time
    rot = float(np.max(np.abs(samples[:, 2]))) * sim_time
    return max(1, math.ceil(max(trans / sim_granularity, rot / angular_granularity)))


@kernel
def _rollout(cos_w, sin_w, inv, vx, vy, use_vy, dt, x0, y0):
    """``_integrate_constant``'s per-sample part, compiled: (T + 1, S) cos, sin (gathered from the
    per-speed (W, T + 1) tables), x and y. Same operations in the same order as the numpy form (step
    ``(vx c - vy s) dt``, or ``vx c dt`` when no sample moves sideways; running sums, then the start
    added), so the same bits."""
    t1, s = cos_w.shape[1], inv.size
    cos_t, sin_t = np.empty((t1, s)), np.empty((t1, s))
    x, y = np.empty((t1, s)), np.empty((t1, s))
    for j in range(s):
        w = inv[j]
        a, b = vx[j], vy[j]
        sx = sy = 0.0
        x[0, j], y[0, j] = x0, y0
        for k in range(t1):
            c, sn = cos_w[w, k], sin_w[w, k]
            cos_t[k, j], sin_t[k, j] = c, sn
            if k + 1 < t1:
                if use_vy:
                    dx, dy = (a * c - b * sn) * dt, (a * sn + b * c) * dt
                else:
                    dx, dy = (a * c) * dt, (a * sn) * dt
                sx = dx if k == 0 else sx + dx
                sy = dy if k == 0 else sy + dy
                x[k + 1, j], y[k + 1, j] = sx + x0, sy + y0
    return cos_t, sin_t, x, y
