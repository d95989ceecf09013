"""The robots' bodies for the MuJoCo engine, from their makers' descriptions. Pure data.

Every number carries its source. Abbreviations:
- JK: github jackal/jackal (noetic-devel), ``jackal_description/urdf/jackal.urdf.xacro`` and
  ``jackal_control/config/control.yaml`` (Clearpath's own description and controller).
- MENAG: github google-deepmind/mujoco_menagerie ``clearpath_jackal/jackal.xml`` (BSD-3, Clearpath 2021,
  built from Clearpath's URDF; licence text in ``robot_side/sim/LICENSE.jackal-menagerie``). Only the
  masses and inertias below are taken from it (they equal JK's).
- BARN: ../shared/datasets/barn/README.md (the challenge's footprint, 0.508 x 0.430 m).
- AMR: github MobileRobots/amr-ros-config ``description/urdf/pioneer3at.urdf.xacro`` (MobileRobots' own).
- ARIA: github reedhedges/AriaCoda ``params/p3at.p``; P2OS: github allenh1/p2os ``p2os_urdf``.
- WB: Webots ``projects/robots/adept/pioneer3/protos/Pioneer3at.proto`` and docs/guide/pioneer-3at.md
  (Adept's datasheet values: 12 kg, 0.7 m/s, 508 x 497 x 277 mm).

Frames: the body's origin is base_link projected onto the floor (z = 0 at rest), x forward, y left, so
a sensor mount's z in the robot YAML is its height above the floor, as in the kinematic engine.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Wheel", "RobotBody", "BODIES", "body_for"]


@dataclass(frozen=True)
class Wheel:
    x: float        # m, axle position in base_link (floor level)
    y: float        # m; > 0: left side
    radius: float   # m
    width: float    # m
    mass: float     # kg
    inertia: tuple[float, float, float]  # kg m^2 about (x, axle y, z) of the wheel


@dataclass(frozen=True)
class RobotBody:
    name: str
    mass: float                                    # kg, the body without wheels
    inertia: tuple[float, float, float]            # kg m^2, diagonal about the centre of mass
    com: tuple[float, float, float]                # m, centre of mass above the floor origin
    hull: tuple[tuple[float, float, float, float], ...]  # collision boxes (cx, cy, sx, sy) in base_link
    hull_z: tuple[float, float]                    # m, bottom and top of the hull above the floor
    wheels: tuple[Wheel, ...]
    wheel_separation: float                        # m, the drive controller's separation
    wheel_separation_multiplier: float             # the controller's skid-steer factor (JK control.yaml)
    wheel_torque_max: float | None                 # N m per wheel motor; None: no published limit
    wheel_speed_max: float                         # rad/s, the motor's top speed
    wheel_armature: float = 0.0                    # kg m^2, the motor's rotor inertia seen at the wheel
    wheel_damping: float = 0.0                     # N m s/rad, viscous loss of the drive train
    wheel_frictionloss: float = 0.0                # N m, dry friction of the drive train
    casters: tuple[tuple[float, float, float], ...] = ()  # frictionless balls (x, y, radius)
    caster_clearance: float = 0.0                  # m between a caster and the floor at rest
    heading_from_gyro: bool = False                # odometry heading from the IMU's yaw rate (ekf)
    gyro_noise: float = 0.0                        # rad/s white noise of the gyro at its rate
    gyro_rate: float = 50.0                        # Hz

    @property
    def total_mass(self) -> float:
        return self.mass + sum(w.mass for w in self.wheels)


# Clearpath Jackal (J100). JK: wheel_radius 0.098, wheel width 0.040, wheelbase 0.262, track 0.37559,
# wheel_vertical_offset 0.0345 (axle above base_link) -> base_link 0.0635 above the floor; chassis_link
# mass 16.523 kg, COM (0.012, 0.002, 0.067) above base_link, inertia ixx 0.3136 iyy 0.3922 izz 0.4485
# (= MENAG); wheel mass 0.477, inertia ixx 0.0013 iyy 0.0024 izz 0.0013 (= MENAG). Hull: BARN's footprint
# 0.508 x 0.430 m (chassis 0.42 x 0.31 plus wheels and fenders), from the 0.065 m ground clearance
# (Clearpath's Jackal user manual, "System Specifications") to 0.25 m (same table: height 250 mm).
# Drive (JK control.yaml, diff_drive_controller): wheel_separation = track, wheel_separation_multiplier
# 1.5. Motors: Clearpath publishes no torque; BARN's Gazebo Jackal drives its wheels through a
# VelocityJointInterface with no effort limit (JK: transmission, no <limit effort>), so none here either:
# the wheels are stiff velocity servos and the tyres' friction limits the acceleration. Top wheel speed:
# MENAG's actuator ctrlrange 26 rad/s (2.5 m/s at r = 0.098). Drive train at each wheel (MENAG's
# "throttle" joint class): armature 0.01 kg m^2 (the geared motor's rotor), damping 0.01, frictionloss
# 0.001. IMU (JK jackal.gazebo, hector imu plugin):
# 50 Hz, rateGaussianNoise 0.005 rad/s; the ekf (JK robot_localization.yaml) fuses the wheel odometry's
# velocities with the IMU's yaw rate.
_JK_R, _JK_Z = 0.098, 0.0635
JACKAL = RobotBody(
    name="jackal", mass=16.523, inertia=(0.3136, 0.3922, 0.4485), com=(0.012, 0.002, _JK_Z + 0.067),
    hull=((0.0, 0.0, 0.508, 0.430),), hull_z=(0.065, 0.25),
    wheels=tuple(Wheel(x, y, _JK_R, 0.040, 0.477, (0.0013, 0.0024, 0.0013))
                 for x in (0.131, -0.131) for y in (0.187795, -0.187795)),
    wheel_separation=0.37559, wheel_separation_multiplier=1.5, wheel_torque_max=None, wheel_speed_max=26.0,
    wheel_armature=0.01, wheel_damping=0.01, wheel_frictionloss=0.001,
    heading_from_gyro=True, gyro_noise=0.005, gyro_rate=50.0)

# Pioneer 3-AT. AMR: base_link mass 21.5 kg ("P3AT 18.6kg plus three batteries @ 2.4kg each minus four
# wheels @ 1.4 kg ea and top plate"), inertia ixx 0.3338 iyy 0.4783 izz 0.3338, COM (-0.1, 0, 0.177);
# wheels: cylinder r 0.111, length 0.075, mass 1.2 kg; axles at x 0.135 / -0.134, y +-(0.156 + 0.041),
# z 0.111 (base_link is on the floor). Hull: zenav's P3-AT footprint (the tutorial's, with the front
# bumper), from 0.06 m (below the axles' housings) to WB's height 0.277 m. Drive: the P2OS / ARCOS
# firmware turns a rotation command into wheel speeds with DiffConvFactor 0.0034 (ARIA p3at.p, also
# robot_side/p2os/sip.py): rotVel = (vR - vL) / 2 * 0.0034, an effective separation of 0.588 m = 1.49 x
# the 0.394 m track (the skid-steer calibration), and reports its odometry with the same factor.
# Motors: WB: maxTorque 20 N m, maxVelocity 6.4 rad/s (0.71 m/s at r = 0.111: the datasheet's 0.7 m/s).
# No source gives the drive train's rotor inertia or losses: none modelled.
P3AT = RobotBody(
    name="p3at", mass=21.5, inertia=(0.3338, 0.4783, 0.3338), com=(-0.1, 0.0, 0.177),
    hull=((0.0, 0.0, 0.508, 0.508), (0.2921, 0.0, 0.0762, 0.1016)), hull_z=(0.06, 0.277),
    wheels=tuple(Wheel(x, y, 0.111, 0.075, 1.2, (0.0043, 0.0074, 0.0043))
                 for x in (0.135, -0.134) for y in (0.197, -0.197)),
    wheel_separation=0.394, wheel_separation_multiplier=(2 / 0.0034) / 1000 / 0.394, wheel_torque_max=20.0,
    wheel_speed_max=6.4)
# (the wheel inertias: a solid cylinder of 1.2 kg, r 0.111, 0.075 long: iyy = m r^2 / 2, ixx = izz =
# m (3 r^2 + l^2) / 12; the URDFs' 0.0152 about the axle is a placeholder larger than the solid value)

# Pioneer LX (differential drive). AMR pioneer-lx.urdf.xacro: 60 kg in all ("60 kg minus each wheel": base
# 57.8 kg, wheels 1.1 kg each), drive wheels r 0.100 m, 0.05 m wide, at (0, +-0.2, 0.1); body box
# 0.7 x 0.5 x 0.35 m centred 0.2 m up (its inertia is a placeholder of 1: ours is the solid box's).
# Hull: ARIA pioneer-lx.p RobotLength 696 / RobotWidth 500 mm, centred (LengthFront = LengthRear = 348).
# Drive: ARIA DiffConvFactor 0.0056 -> rotVel = (vR - vL)/2 * 0.0056: a separation of 0.357 m, which the
# firmware uses for commands and odometry (0.893 x the URDF's 0.4 m). Motors: no published torque or speed
# limit; the 1.8 m/s TransVelMax at r = 0.1 is 18 rad/s. Casters: no source gives their positions:
# two frictionless balls on the centre line 0.25 m ahead of and behind the axle, 5 mm clear of the floor
# (our choice: the weight rests on the drive wheels, a caster catches the body when it pitches 1 degree).
_LX_BOX = (0.7, 0.5, 0.35)
PIONEER_LX = RobotBody(
    name="pioneer_lx", mass=57.8, com=(0.0, 0.0, 0.2),
    inertia=(57.8 * (_LX_BOX[1] ** 2 + _LX_BOX[2] ** 2) / 12, 57.8 * (_LX_BOX[0] ** 2 + _LX_BOX[2] ** 2) / 12,
             57.8 * (_LX_BOX[0] ** 2 + _LX_BOX[1] ** 2) / 12),
    hull=((0.0, 0.0, 0.696, 0.5),), hull_z=(0.05, 0.4),
    wheels=(Wheel(0.0, 0.2, 0.1, 0.05, 1.1, (0.003, 0.0055, 0.003)),
            Wheel(0.0, -0.2, 0.1, 0.05, 1.1, (0.003, 0.0055, 0.003))),
    wheel_separation=0.4, wheel_separation_multiplier=(2 / 0.0056) / 1000 / 0.4, wheel_torque_max=None,
    wheel_speed_max=18.0, casters=((0.25, 0.0, 0.04), (-0.25, 0.0, 0.04)), caster_clearance=0.005)

BODIES: dict[str, RobotBody] = {"jackal": JACKAL, "p3at": P3AT, "pioneer_lx": PIONEER_LX}


def body_for(model: str | None) -> RobotBody:
    """The body of a base ``model`` (``BASE_PRESETS`` name; ``None`` = the default P3-AT)."""
    return BODIES[model or "p3at"]
