"""Parameters of the simulated base (``robot_side.sim.base``): the robots' presets (P3-AT, Jackal, Pioneer LX)
and their loading from a robot file's ``base:`` mapping. Each figure's source is beside it."""

from __future__ import annotations

import builtins
import math
from dataclasses import dataclass

from common.config import ConfigError, load_params, param

__all__ = ["BaseParams", "P3AT_FOOTPRINT", "JACKAL_FOOTPRINT", "LX_FOOTPRINT", "BASE_PRESETS", "base_preset",
           "load_base_params"]

P3AT_FOOTPRINT = ((0.3302, -0.0508), (0.254, -0.0508), (0.254, -0.254), (-0.254, -0.254), (-0.254, 0.254),
                  (0.254, 0.254), (0.254, 0.0508), (0.3302, 0.0508))


@dataclass(frozen=True)
class BaseParams:
    model: builtins.str = param("p3at", choices=("p3at", "jackal", "pioneer_lx"),
                                doc="the robot (BASE_PRESETS: its defaults; the MuJoCo engine: its body)")
    footprint: tuple[tuple[float, float], ...] = param(P3AT_FOOTPRINT, unit="m", doc="polygon in base_link")
    max_vel_x: float = param(0.7, lo=0.0, hi=10.0, unit="m/s", doc="max |forward speed| (P3-AT: 0.7)")
    max_vel_theta: float = param(math.radians(140), lo=0.0, hi=20.0, unit="rad/s", doc="max |rotation speed|")
    acc_lim_x: float = param(1.0, lo=0.01, hi=1000.0, unit="m/s^2", doc="linear acceleration limit")
    acc_lim_th: float = param(2.0, lo=0.01, hi=1000.0, unit="rad/s^2", doc="angular acceleration limit")
    decel_lim_x: float | None = param(None, lo=0.01, hi=1000.0, unit="m/s^2",
                                      doc="linear braking limit; default acc_lim_x")
    decel_lim_th: float | None = param(None, lo=0.01, hi=1000.0, unit="rad/s^2",
                                       doc="angular braking limit; default acc_lim_th")
    cmd_vel_timeout: float = param(0.25, lo=0.0, hi=60.0, unit="s",
                                   doc="brake to a stop when no cmd_vel for this long")
    motors_enabled: bool = param(True, doc="motors enabled at start (p2os cmd_motor_state)")
    # `builtins.str`: the gmapping field named `str` shadows the builtin when type hints are resolved
    odom_frame_id: builtins.str = param("odom", doc="odometry frame")
    base_frame_id: builtins.str = param("base_link", doc="robot frame")
    srr: float = param(0.01, lo=0.0, hi=10.0, doc="translation error from translation (m per sqrt(m))")
    srt: float = param(0.02, lo=0.0, hi=10.0, doc="translation error from rotation (m per sqrt(rad))")
    str: float = param(0.01, lo=0.0, hi=10.0, doc="rotation error from translation (rad per sqrt(m))")
    stt: float = param(0.02, lo=0.0, hi=10.0, doc="rotation error from rotation (rad per sqrt(rad))")
    collision_debounce: float = param(0.5, lo=0.0, hi=60.0, unit="s",
                                      doc="a contact after this long without one is a new collision")
    min_obstacle_height: float = param(0.02, lo=0.0, hi=10.0, unit="m", doc="lower cells do not collide")
    seed: int = param(0, lo=0, doc="odometry noise RNG seed")
    odom_rotation_center_x: float = param(
        0.0, lo=-2.0, hi=2.0, unit="m",
        doc="where on base_link's x axis the odometry takes the base to turn about (zenav; as p2os's "
            "odom_rotation_center_x: a skid-steered base pivots toward its more loaded axle, `python "
            "bench/turning.py`); 0: about base_link, as wheel odometry integrates")
    odom_start_yaw_from_world: bool = param(False, doc="odometry starts at (0, 0, start yaw) instead of "
                                                       "(0, 0, 0): odom axes aligned with the world's")
    gyro: bool = param(False, doc="the odometry's heading from the base's gyro, not its wheels (the P3-AT's "
                                  "optional gyro, which ARCOS firmware integrates into the pose its SIPs report; "
                                  "str / stt then do not apply)")
    gyro_scale_error: float = param(0.03, lo=-0.5, hi=0.5, doc="the gyro's rate scale error (ARIA's "
                                    "ArAnalogGyro: its default scaling within 3 % of correct most of the time)")
    gyro_noise: float = param(math.radians(0.1), lo=0.0, hi=1.0, unit="rad/sqrt(s)",
                              doc="the gyro's angle random walk while the base moves (ARIA's fusion: 0.001 deg^2 "
                                  "per 0.1 s report; a standing base's rate is zeroed)")
    gyro_turn_noise: float = param(math.sqrt(0.001 * math.pi / 180.0), lo=0.0, hi=1.0, unit="rad/sqrt(rad)",
                                   doc="the gyro's heading error growing with the turn (ARIA's fusion: 0.001 deg^2 "
                                       "per degree turned; its wheels: 0.25)")

    def validate(self) -> None:
        if len(self.footprint) < 3:
            raise ValueError("footprint needs at least 3 points")


# Clearpath Jackal as simulated by the BARN challenge. Footprint 0.508 x 0.430 m centred on base_link
# (../shared/datasets/barn/README.md). Limits from jackal_control/config/control.yaml (github jackal/jackal,
# jackal_velocity_controller): linear.x max_velocity 2.0 m/s, max_acceleration 20.0 m/s^2; angular.z
# max_velocity 4.0 rad/s, max_acceleration 25.0 rad/s^2; cmd_vel_timeout 0.25 s. Odometry fused with an
# IMU (robot_localization ekf with the IMU's absolute yaw): small errors, little heading drift (our choice).
JACKAL_FOOTPRINT = ((0.254, 0.215), (-0.254, 0.215), (-0.254, -0.215), (0.254, -0.215))
# Pioneer LX (ARIA pioneer-lx.p): RobotLength 696 / RobotWidth 500 mm centred on base_link; TransVelMax
# 1800 mm/s, RotVelMax 180 deg/s, TransAccel 500 / TransDecel 600 mm/s^2, RotAccel 150 / RotDecel 200 deg/s^2.
LX_FOOTPRINT = ((0.348, 0.25), (-0.348, 0.25), (-0.348, -0.25), (0.348, -0.25))
BASE_PRESETS: dict[str, dict] = {
    "p3at": {},
    "pioneer_lx": dict(footprint=LX_FOOTPRINT, max_vel_x=1.8, max_vel_theta=math.pi, acc_lim_x=0.5, decel_lim_x=0.6,
                       acc_lim_th=math.radians(150), decel_lim_th=math.radians(200)),
    "jackal": dict(footprint=JACKAL_FOOTPRINT, max_vel_x=2.0, max_vel_theta=4.0, acc_lim_x=20.0,
                   acc_lim_th=25.0, cmd_vel_timeout=0.25, srr=0.01, srt=0.01, str=0.002, stt=0.005,
                   odom_start_yaw_from_world=True),
}


def base_preset(name: str, **overrides) -> BaseParams:
    """``base_preset("jackal", seed=3)`` -> BaseParams."""
    return BaseParams(**{**BASE_PRESETS[name], "model": name, **overrides})


def load_base_params(mapping: dict | None, source: str = "<config>", section: str = "base") -> BaseParams:
    """Like ``load_params`` but an optional ``model:`` key (a ``BASE_PRESETS`` name) sets the defaults."""
    m = dict(mapping or {})
    model = m.pop("model", None)
    if model is not None:
        if model not in BASE_PRESETS:
            raise ConfigError(source, f"{section}.model", f"{model!r} is not one of {sorted(BASE_PRESETS)}")
        m = {**BASE_PRESETS[model], **m, "model": model}
    return load_params(BaseParams, m, source, section)
