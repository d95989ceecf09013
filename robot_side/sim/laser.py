"""Simulated planar laser rangefinder (ROS sensor_msgs/LaserScan semantics).

Ranges are exact grid ray casts (see ``raycast``) from the mount point; only obstacles taller than the
mount height ``z`` are hit. Output (REP 117): ``+inf`` no return within ``range_max``, ``-inf`` a return
closer than ``range_min``; gaussian noise (``noise_std``) is added to returns before that test.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from common.config import ConfigError, load_params, param
from common.geometry import Pose2D
from common.messages import Header, LaserScan
from robot_side.sim.raycast import SurfaceCells, candidates, expand_pairs, ray_square, safe_inverse, surface_cells
from robot_side.sim.world import World

__all__ = ["LaserParams", "Laser", "LASER_PRESETS", "load_laser_params"]


@dataclass(frozen=True)
class LaserParams:
    angle_min: float = param(-math.radians(135), lo=-math.pi, hi=math.pi, unit="rad", doc="first beam angle")
    angle_max: float = param(math.radians(135), lo=-math.pi, hi=math.pi, unit="rad", doc="last beam angle")
    samples: int = param(541, lo=2, hi=100000, aliases=("beam_count",), doc="number of beams")
    range_min: float = param(0.05, lo=0.0, hi=1000.0, unit="m", doc="closer returns are reported as -inf")
    range_max: float = param(30.0, lo=0.01, hi=1000.0, unit="m", doc="no return within it is +inf")
    noise_std: float = param(0.01, lo=0.0, hi=10.0, unit="m", aliases=("stddev",), doc="gaussian range noise")
    rate: float = param(25.0, lo=0.1, hi=1000.0, unit="Hz", aliases=("update_rate",), doc="scan frequency")
    x: float = param(0.1, lo=-10.0, hi=10.0, unit="m", doc="mount x in base_link")
    y: float = param(0.0, lo=-10.0, hi=10.0, unit="m", doc="mount y in base_link")
    z: float = param(0.35, lo=0.0, hi=10.0, unit="m", doc="mount height; only taller obstacles are seen")
    yaw: float = param(0.0, lo=-math.pi, hi=math.pi, unit="rad", doc="mount yaw in base_link")
    frame_id: str = param("laser", doc="frame of the scan")
    topic: str = param("scan", doc="bus topic the simulator node publishes the scan on")
    seed: int = param(1, lo=0, doc="noise RNG seed")

    def validate(self) -> None:
        if self.angle_max <= self.angle_min:
            raise ValueError("angle_max must be greater than angle_min")
        if self.range_max <= self.range_min:
            raise ValueError("range_max must be greater than range_min")
        if not self.topic.strip("/") or any(c in self.topic for c in "*$#? "):
            raise ValueError(f"topic {self.topic!r} is not a topic name")

    @property
    def angle_increment(self) -> float:
        return (self.angle_max - self.angle_min) / (self.samples - 1)

    @property
    def mount(self) -> Pose2D:
        return Pose2D(self.x, self.y, self.yaw)


# Datasheet values: SICK S300 (270 deg, 0.5 deg, 40 ms scan, 30 m), Hokuyo URG-04LX (240 deg, 683 steps,
# 100 ms scan, 0.02..5.6 m, accuracy +-10 mm below 1 m). Hokuyo UST-10LX as the BARN challenge simulates
# it (../shared/datasets/barn/README.md; jackal_description hokuyo_ust10.urdf.xacro: 720 samples over
# +-2.35619 rad, 0.1..30 m, 50 Hz, gaussian noise stddev 0.001 m); the Jackal publishes it on front/scan
# in frame front_laser.
LASER_PRESETS: dict[str, dict] = {
    "sick_s300": dict(angle_min=-math.radians(135), angle_max=math.radians(135), samples=541,
                      range_min=0.05, range_max=30.0, noise_std=0.01, rate=25.0),
    "hokuyo_urg04lx": dict(angle_min=-math.radians(120), angle_max=math.radians(120), samples=683,
                           range_min=0.02, range_max=5.6, noise_std=0.01, rate=10.0),
    "hokuyo_ust10lx": dict(angle_min=-2.35619, angle_max=2.35619, samples=720, range_min=0.1, range_max=30.0,
                           noise_std=0.001, rate=50.0),
}


def load_laser_params(mapping: dict | None, source: str = "<config>", section: str = "laser") -> LaserParams:
    """Like ``load_params`` but an optional ``model:`` key (a ``LASER_PRESETS`` name) sets the defaults."""
    m = dict(mapping or {})
    model = m.pop("model", None)
    if model is not None:
        if model not in LASER_PRESETS:
            raise ConfigError(source, f"{section}.model", f"{model!r} is not one of {sorted(LASER_PRESETS)}")
        m = {**LASER_PRESETS[model], **m}
    return load_params(LaserParams, m, source, section)


class Laser:
    """Renders ``LaserScan`` messages of a ``World`` from a robot pose."""

    def __init__(self, world: World, params: LaserParams = LaserParams(), cells: SurfaceCells | None = None):
        """``cells``: the world's surface cells at this mount height when already computed (several
        sensors at one height share them: a sonar ring)."""
        self.world, self.p = world, params
        if cells is None:
            self.refresh()
        else:
            self.cells = cells
        self.angles = params.angle_min + params.angle_increment * np.arange(params.samples)
        self.rng = np.random.default_rng(params.seed)
        self.scan_time = 1.0 / params.rate

    def refresh(self) -> None:
        """Re-read the world's surface (after ``World.add_box``)."""
        self.cells = surface_cells(self.world.heights, self.world.origin, self.world.resolution, threshold=self.p.z)

    def sensor_pose(self, robot: Pose2D) -> Pose2D:
        return robot.compose(self.p.mount)

    def ranges_exact(self, robot: Pose2D) -> np.ndarray:
        """Noise-free float64 distances to the first hit per beam (+inf none within range_max)."""
        p, res = self.p, self.world.resolution
        s = self.sensor_pose(robot)
        n = p.samples
        out = np.full(n, np.inf)
        ci, bearing, half, _ = candidates(self.cells, s.x, s.y, s.theta, p.range_max)
        if p.angle_max - p.angle_min > math.pi:  # intervals crossing +-pi: add shifted copies
            wrap = (bearing - half < -math.pi) | (bearing + half > math.pi)
            if wrap.any():
                k = np.flatnonzero(wrap)
                shift = np.where(bearing[k] > 0, -2 * math.pi, 2 * math.pi)
                ci = np.concatenate((ci, ci[k]))
                bearing = np.concatenate((bearing, bearing[k] + shift))
                half = np.concatenate((half, half[k]))
        inc = p.angle_increment
        lo = np.maximum(np.ceil((bearing - half - p.angle_min) / inc), 0).astype(np.int64)
        hi = np.minimum(np.floor((bearing + half - p.angle_min) / inc), n - 1).astype(np.int64)
        ok = hi >= lo
        which, beam = expand_pairs(lo[ok], hi[ok])
        cell = ci[ok][which]
        world_ang = self.angles + s.theta
        inv_dx, inv_dy = safe_inverse(np.cos(world_ang)), safe_inverse(np.sin(world_ang))
        t_in, t_out = ray_square(self.cells.x0[cell] - s.x, self.cells.y0[cell] - s.y,
                                 inv_dx[beam], inv_dy[beam], res)
        np.maximum(t_in, 0.0, out=t_in)
        hit = t_out > t_in
        np.minimum.at(out, beam[hit], t_in[hit])
        out[out > p.range_max] = np.inf
        return out

    def scan(self, robot: Pose2D, stamp: float = 0.0) -> LaserScan:
        p = self.p
        r = self.ranges_exact(robot)
        finite = np.isfinite(r)
        if p.noise_std > 0:
            r[finite] += self.rng.normal(0.0, p.noise_std, int(finite.sum()))
        r[finite & (r > p.range_max)] = np.inf
        r[finite & (r < p.range_min)] = -np.inf
        full_turn = max(p.samples - 1, 1) * 2 * math.pi / (p.angle_max - p.angle_min)
        return LaserScan(
            header=Header(stamp, p.frame_id), angle_min=p.angle_min, angle_max=p.angle_max,
            angle_increment=p.angle_increment, time_increment=self.scan_time / full_turn,
            scan_time=self.scan_time, range_min=p.range_min, range_max=p.range_max,
            ranges=r.astype(np.float32))

    @staticmethod
    def preset(name: str, **overrides) -> LaserParams:
        """``Laser.preset("sick_s300", z=0.3)`` -> LaserParams."""
        return dataclasses.replace(LaserParams(**LASER_PRESETS[name]), **overrides)
