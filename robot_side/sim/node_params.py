"""Parameters of the simulator bus node (``robot_side.sim.node``) that the pure Simulator does not have, the
node's mapping loaded into them and a Simulator, and the line the node starts with."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from common.config import ConfigError, load_params, param
from robot_side.sim.simulator import Simulator, resolve_world

__all__ = ["SimNodeParams", "SIMULATOR_KEYS", "CAMERA_LINK", "load", "describe"]

CAMERA_LINK = "camera_link"  # the Kinect's mount frame (the tutorial's static transform names it)

# keys of the node's mapping that go to ``Simulator.from_config``; every other key is a SimNodeParams field
SIMULATOR_KEYS = ("world", "start", "world_params", "sim", "base", "laser", "depth_camera", "sonar", "engine",
                  "physics")


@dataclass(frozen=True)
class SimNodeParams:
    speed: float | None = param(None, lo=0.01, hi=1000.0, aliases=("real_time_factor",),
                                doc="sim seconds per wall second (N<1 too); default sim.real_time_factor")
    start_time: float | None = param(None, lo=0.0, unit="s",
                                     doc="sim time at start; default the wall time at start (consistent "
                                         "stamps for nodes on the wall clock at speed 1)")
    default_world: str = param("room", doc="world used when the mapping has no 'world'")
    odom_rate: float = param(50.0, lo=0.1, hi=1000.0, unit="Hz", doc="odom + tf odom->base_link (sim time)")
    ground_truth_rate: float = param(50.0, lo=0.1, hi=1000.0, unit="Hz", doc="ground_truth (sim time)")
    motor_state_rate: float = param(1.0, lo=0.01, hi=100.0, unit="Hz", doc="motor_state, also sent on change")
    battery_rate: float = param(1.0, lo=0.01, hi=100.0, unit="Hz", doc="battery_state (sim time)")
    battery_start: float = param(1.0, lo=0.0, hi=1.0, doc="charge fraction at start")
    battery_drain_per_hour: float = param(0.25, lo=0.0, hi=100.0, doc="charge fraction lost per sim hour")
    battery_empty_voltage: float = param(11.0, lo=0.0, hi=100.0, unit="V", doc="voltage at 0 %")
    battery_full_voltage: float = param(12.8, lo=0.0, hi=100.0, unit="V", doc="voltage at 100 % (12 V SLA)")
    bumper_rate: float = param(0.0, lo=0.0, hi=100.0, unit="Hz",
                               doc="bumper_state (the P3-AT's bumpers, robot_side/bumpers/geometry.py), each the "
                                   "segments pressed since the last; 0: no bumpers (a P2OS SIP cycle: 10)")
    mount_tf: bool = param(True, doc="publish base_link->laser and base_link->camera_link from the sensor "
                                     "mounts; false when a static transform node owns those edges (the "
                                     "sim then publishes camera_link->camera_depth_frame so that the chain "
                                     "ends at the pose it renders)")
    depth_frame_id: str = param("camera_depth_frame", doc="x-forward frame of the depth sensor (openni)")
    cmd_vel_topic: str = param("cmd_vel", doc="velocity commands (safety/cmd_vel behind the collision monitor)")
    max_lag: float = param(0.5, lo=0.01, hi=60.0, unit="s",
                           doc="wall seconds behind schedule before the pacer gives up catching up")

    def validate(self) -> None:
        if self.battery_full_voltage < self.battery_empty_voltage:
            raise ValueError("battery_full_voltage must be >= battery_empty_voltage")


def load(cfg: dict | None, source: str) -> tuple[SimNodeParams, Simulator, str]:
    cfg = dict(cfg or {})
    sim_cfg = {k: cfg.pop(k) for k in SIMULATOR_KEYS if k in cfg}
    names = {a for f in dataclasses.fields(SimNodeParams) for a in (f.name, *f.metadata.get("aliases", ()))}
    for k in cfg:
        if k not in names:
            known = ", ".join(sorted((*SIMULATOR_KEYS, *names)))
            raise ConfigError(source, str(k), f"unknown key (known keys: {known})")
    p = load_params(SimNodeParams, cfg, source)
    sim_cfg.setdefault("world", p.default_world)
    for sensor in ("laser", "depth_camera"):  # absent = no such sensor (one scan publisher per robot)
        sim_cfg.setdefault(sensor, None)
    sim = Simulator.from_config(sim_cfg, source)
    if sim.camera is not None and sim.camera.p.frame_id in (CAMERA_LINK, p.depth_frame_id):
        raise ConfigError(source, "depth_camera.frame_id",
                          f"must name the optical frame, not {sim.camera.p.frame_id!r}")
    return p, sim, str(resolve_world(sim_cfg["world"], source))


def describe(sim: Simulator, p: SimNodeParams, speed: float, world_path: str = "") -> str:
    """The simulator's start line: world, start, sensors, engine, speed and clock."""
    s, b = sim, sim.base
    parts = [f"world '{s.world.name}' ({world_path})" if world_path else f"world '{s.world.name}'",
             f"start x={b.pose.x:.2f} y={b.pose.y:.2f} yaw={b.pose.theta:.2f}"]
    if s.laser:
        lp = s.laser.p
        fov = math.degrees(lp.angle_max - lp.angle_min)
        parts.append(f"laser '{lp.frame_id}' on {lp.topic} {lp.samples} beams {fov:.0f} deg "
                     f"{lp.range_max:g} m {lp.rate:g} Hz")
    if s.camera:
        cp = s.camera.p
        parts.append(f"depth '{cp.frame_id}' {s.camera.width}x{s.camera.height} {cp.publish_rate:g} Hz")
    if not (s.laser or s.camera):
        parts.append("no sensors")
    start = "wall time" if p.start_time is None else f"{p.start_time:g} s"
    if s.params.engine == "mujoco":
        ph = s.base.phys
        parts.append(f"engine mujoco ({s.base.body.name} body, physics step {ph.timestep * 1e3:g} ms, "
                     f"friction {ph.friction:g})")
    else:
        parts.append("engine kinematic")
    parts.append(f"speed {speed:g}x, dt {s.params.dt:g} s, sim time from {start}, "
                 f"{p.cmd_vel_topic} timeout {b.p.cmd_vel_timeout:g} s")
    return "simulator: " + ", ".join(parts)
