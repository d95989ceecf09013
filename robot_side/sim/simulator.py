"""The simulator core: world + Pioneer base + sensors + a simulated clock. Pure and seeded.

The bus node drives it::

    sim = Simulator.from_config(cfg, source)          # or Simulator(world, base_params, laser_params, ...)
    pacer = Pacer(sim.params.real_time_factor)
    while running:
        for _ in range(pacer.steps_due(wall_elapsed, sim.time, sim.params.dt)):
            for sensor in sim.step():                  # "laser" / "depth_camera" when due
                publish(sim.scan() if sensor == "laser" else sim.depth_frame())
        publish(sim.odometry()); publish(sim.clock())
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from common.config import ConfigError, load_params, param
from common.geometry import OPTICAL_FROM_LINK, Pose2D, Transform
from common.messages import (
    CameraInfo,
    Clock,
    Collision,
    DepthImage,
    Header,
    LaserScan,
    MotorState,
    Odometry,
    SonarArray,
    TransformStamped,
    Twist,
)
from robot_side.depth.node_util import split_params
from robot_side.sim.base import BaseParams, DiffDriveBase, load_base_params
from robot_side.sim.depth_camera import (
    DepthCamera,
    DepthCameraParams,
    load_depth_camera_params,
)
from robot_side.sim.laser import Laser, LaserParams, load_laser_params
from robot_side.sim.mujoco_scene import import_mujoco
from robot_side.sim.physics_params import ENGINES, PhysicsParams
from robot_side.sim.sonar import SimSonar, SimSonarParams
from robot_side.sim.world import World, WorldParams, load_world, parse_pose
from robot_side.sonar.geometry import SonarRingParams

__all__ = ["SimulatorParams", "Simulator", "Pacer", "WORLDS_DIR", "resolve_world"]

WORLDS_DIR = Path(__file__).resolve().parents[1] / "worlds"


@dataclass(frozen=True)
class SimulatorParams:
    dt: float = param(0.01, lo=1e-4, hi=0.5, unit="s", doc="physics step")
    real_time_factor: float = param(1.0, lo=0.01, hi=1000.0, doc="simulated seconds per wall second")
    seed: int | None = param(None, lo=0,
                             doc="if set, overrides the base/laser/camera/physics/sonar seeds (seed .. seed+4)")
    map_frame_id: str = param("map", doc="frame of the ground truth (the world)")
    engine: str = param("kinematic", choices=ENGINES,
                        doc="kinematic: exact arcs on the grid (fast, exact geometry); mujoco: rigid-body "
                            "physics (slip, inertia, torque limits), sensors by MuJoCo ray casting")


def resolve_world(name: str | Path, source: str = "<config>") -> Path:
    """A world path as given, or relative to ``robot_side/worlds`` (``room`` -> worlds/room.yaml)."""
    p = Path(name)
    for cand in (p, WORLDS_DIR / p, WORLDS_DIR / f"{p}.yaml"):
        if cand.is_file():
            return cand
    raise ConfigError(source, "world", f"world file {name!s} not found (also looked in {WORLDS_DIR})")


_BASE, _LASER, _CAMERA, _SIM = BaseParams(), LaserParams(), DepthCameraParams(), SimulatorParams()
_PHYS = PhysicsParams()


class Simulator:
    """World + base + sensors + clock. ``laser`` / ``depth_camera`` None: no such sensor."""

    def __init__(self, world: World, base: BaseParams = _BASE, laser: LaserParams | None = _LASER,
                 depth_camera: DepthCameraParams | None = _CAMERA, params: SimulatorParams = _SIM,
                 start: Pose2D | None = None, physics: PhysicsParams = _PHYS,
                 sonar: tuple[SonarRingParams, SimSonarParams] | None = None):
        """``sonar``: the ring's geometry and the simulated sonars' parameters; None: no sonars."""
        if params.seed is not None:
            base = dataclasses.replace(base, seed=params.seed)
            laser = laser and dataclasses.replace(laser, seed=params.seed + 1)
            depth_camera = depth_camera and dataclasses.replace(depth_camera, seed=params.seed + 2)
            physics = dataclasses.replace(physics, seed=params.seed + 3)
            sonar = sonar and (sonar[0], dataclasses.replace(sonar[1], seed=params.seed + 4))
        self.world, self.params = world, params
        # the engine's base and sensors (robot_side.sim.mujoco_* for MuJoCo): the same methods either way
        self.base: Any
        self.laser: Any
        self.camera: Any
        if params.engine == "mujoco":
            from robot_side.sim.mujoco_base import MujocoBase
            from robot_side.sim.mujoco_sensors import RayDepthCamera, RayLaser

            self.base = MujocoBase(world, base, physics, start)
            self.laser = RayLaser(self.base, laser) if laser is not None else None
            self.camera = RayDepthCamera(self.base, depth_camera) if depth_camera is not None else None

            def fan(lp: LaserParams, first: Laser | None) -> Laser:  # MuJoCo's rays share nothing
                return RayLaser(self.base, lp)
        else:
            self.base = DiffDriveBase(world, base, start)
            self.laser = Laser(world, laser) if laser is not None else None
            self.camera = DepthCamera(world, depth_camera) if depth_camera is not None else None

            def fan(lp: LaserParams, first: Laser | None) -> Laser:
                return Laser(world, lp, cells=None if first is None else first.cells)
        self.sonar = SimSonar(sonar[0], sonar[1], fan) if sonar is not None else None
        self.time = 0.0
        self._periods = {}
        if self.laser:
            self._periods["laser"] = 1.0 / laser.rate
        if self.camera:
            self._periods["depth_camera"] = 1.0 / depth_camera.publish_rate
        if sonar is not None:
            self._periods["sonar"] = 1.0 / sonar[1].rate
        # tick 0 is t = 0, before the first step: the first reading is at one period, then every period
        self._last_tick = {k: 0 for k in self._periods}

    @classmethod
    def from_config(cls, cfg: dict, source: str = "<config>") -> Simulator:
        """Build from a node mapping: world, start, world_params, sim, base, laser, depth_camera, sonar,
        engine, physics (``engine: mujoco`` is short for ``sim: {engine: mujoco}``; ``physics``: PhysicsParams).

        ``laser`` / ``depth_camera``: a mapping of params (``laser.model`` picks a preset), or null/false to
        leave the sensor out; absent means defaults. ``sonar``: absent, null or false for none; a mapping of
        ``SimSonarParams`` and ``SonarRingParams`` keys (``{}``: the P3-AT's ring) for a sonar ring.
        """
        known = {"world", "start", "world_params", "sim", "base", "laser", "depth_camera", "sonar", "engine",
                 "physics"}
        for k in cfg:
            if k not in known:
                raise ConfigError(source, str(k), f"unknown key (known keys: {', '.join(sorted(known))})")
        if "world" not in cfg:
            raise ConfigError(source, "world", "missing (a world YAML, e.g. room or corridor)")
        wp = load_params(WorldParams, cfg.get("world_params"), source, "world_params")
        start = parse_pose(cfg["start"], source, "start") if cfg.get("start") is not None else None
        world = load_world(resolve_world(cfg["world"], source), wp, start)

        def sensor(key: str, loader: Any):
            v = cfg.get(key, {})
            return None if v is None or v is False else loader(v, source, key)

        sim_cfg = dict(cfg.get("sim") or {})
        if cfg.get("engine") is not None:
            sim_cfg["engine"] = cfg["engine"]
        params = load_params(SimulatorParams, sim_cfg, source, "sim")
        physics = load_params(PhysicsParams, cfg.get("physics"), source, "physics")
        if params.engine == "mujoco":
            try:
                import_mujoco()
            except RuntimeError as e:
                raise ConfigError(source, "engine", str(e)) from None
        sonar = None
        if cfg.get("sonar") not in (None, False):
            if not isinstance(cfg["sonar"], dict):
                raise ConfigError(source, "sonar", f"a mapping of sonar parameters ({{}} for the P3-AT's ring), "
                                                   f"or null / false for none; got {cfg['sonar']!r}")
            ring, sim_sonar = split_params(cfg["sonar"], source, SonarRingParams, SimSonarParams, section="sonar")
            sonar = (ring, sim_sonar)
        return cls(world, load_base_params(cfg.get("base"), source), sensor("laser", load_laser_params),
                   sensor("depth_camera", load_depth_camera_params), params, physics=physics, sonar=sonar)

    # ------------------------------------------------------------------ time
    def step(self, dt: float | None = None) -> list[str]:
        """Advance physics by ``dt`` (default ``params.dt``); return the sensors due at the new time."""
        dt = self.params.dt if dt is None else dt
        self.time = round(self.time + dt, 9)  # ns rounding: no float drift over long runs
        self.base.step(dt, self.time)
        due = []
        for name, period in self._periods.items():
            tick = math.floor(self.time / period + 1e-6)
            if tick > self._last_tick[name]:
                self._last_tick[name] = tick
                due.append(name)
        return due

    # ------------------------------------------------------------------ inputs
    def add_box(self, cx: float, cy: float, sx: float, sy: float, height: float, yaw: float = 0.0) -> None:
        """A box appears in the world (world frame, metres): the base collides with it, sensors see it."""
        self.world.add_box(cx, cy, sx, sy, height, yaw)
        if self.params.engine == "mujoco":
            from robot_side.sim.world_shapes import Box

            self.base.add_box(Box(cx, cy, sx, sy, yaw, height))
        for sensor in (self.laser, self.camera, self.sonar):
            if sensor is not None:
                sensor.refresh()

    def cmd_vel(self, twist: Twist) -> None:
        self.base.set_cmd_vel(twist, self.time)

    def set_motors(self, enabled: bool) -> None:
        self.base.set_motors(enabled)

    # ------------------------------------------------------------------ outputs
    @property
    def ground_truth(self) -> Pose2D:
        return self.base.pose

    def scan(self) -> LaserScan:
        if self.laser is None:
            raise RuntimeError("no laser configured")
        return self.laser.scan(self.base.pose, self.time)

    def depth_frame(self) -> tuple[DepthImage, CameraInfo]:
        if self.camera is None:
            raise RuntimeError("no depth camera configured")
        return self.camera.frame(self.base.pose, self.time), self.camera.camera_info(self.time)

    def sonar_reading(self) -> SonarArray:
        if self.sonar is None:
            raise RuntimeError("no sonar configured")
        return self.sonar.reading(self.base.pose, self.time)

    def odometry(self) -> Odometry:
        return self.base.odometry(self.time)

    def ground_truth_odometry(self) -> Odometry:
        """Ground-truth pose and velocity in the map (world) frame, for evaluation."""
        b = self.base
        return Odometry(Header(self.time, self.params.map_frame_id), b.p.base_frame_id,
                        b.pose.to_transform(), Twist.planar(b.v, b.w))

    def odom_transform(self) -> TransformStamped:
        """odom -> base_link from the (noisy) odometry."""
        b = self.base
        return TransformStamped(Header(self.time, b.p.odom_frame_id), b.p.base_frame_id,
                                b.odom.to_transform())

    def static_transforms(self) -> list[TransformStamped]:
        """base_link -> laser, base_link -> camera_link, camera_link -> optical frame."""
        base = self.base.p.base_frame_id
        out = []
        if self.laser:
            lp = self.laser.p
            out.append(TransformStamped(Header(0.0, base), lp.frame_id,
                                        Transform.from_xyz_rpy(lp.x, lp.y, lp.z, 0.0, 0.0, lp.yaw)))
        if self.camera:
            cp = self.camera.p
            out.append(TransformStamped(Header(0.0, base), "camera_link",
                                        Transform.from_xyz_rpy(cp.x, cp.y, cp.z, 0.0, 0.0, cp.yaw)))
            out.append(TransformStamped(Header(0.0, "camera_link"), cp.frame_id, OPTICAL_FROM_LINK))
        return out

    def clock(self) -> Clock:
        return Clock(self.time)

    def collision(self) -> Collision:
        return self.base.collision(self.time, self.params.map_frame_id)

    def motor_state(self) -> MotorState:
        return MotorState(Header(self.time, self.base.p.base_frame_id), self.base.motors_enabled)


class Pacer:
    """How many physics steps to run so sim time tracks ``factor`` x wall time (pure: pass the clocks)."""

    def __init__(self, factor: float = 1.0, max_steps: int = 1000):
        self.factor, self.max_steps = factor, max_steps

    def steps_due(self, wall_elapsed: float, sim_time: float, dt: float) -> int:
        behind = wall_elapsed * self.factor - sim_time
        return max(0, min(self.max_steps, math.floor(behind / dt + 1e-9)))
