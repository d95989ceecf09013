"""The robot's base on MuJoCo: cmd_vel -> the base's own wheel-velocity controller -> wheel motors ->
tyres on the floor. The same surface as the kinematic ``DiffDriveBase`` (pose, odom, v, w, collisions,
contact, set_cmd_vel, step, odometry, collision), so the simulator node cannot tell them apart.

Per physics step (``PhysicsParams.timestep``):

1. the controller (diff_drive_controller's role, or the P2OS firmware's): the command, zero after
   ``cmd_vel_timeout``, clamped to the velocity limits and ramped at the acceleration limits of
   ``BaseParams`` (as the kinematic engine), becomes wheel speeds with the body's controller separation
   x ``wheel_separation_multiplier``: ω_l,r = (v ∓ w s/2) / r, each clipped to the motor's top speed;
2. each wheel's motor driver closes a PI loop on its wheel's speed (as the robots' motor controllers
   do; ``WheelSpeedLoop``), its torque clipped to the motor's limit (``robot_bodies``), the integral
   held while clipped; MuJoCo moves the body, with slip, inertia and contacts;
3. odometry as the robot computes it: v = r (ω_l + ω_r)/2 and w = r (ω_r - ω_l)/s from the wheel
   joints, or w from a gyro (the true yaw rate plus white noise, sampled at the gyro's rate) for bodies
   whose ekf fuses the IMU (the Jackal), or with ``BaseParams.gyro`` (the P3-AT's optional gyro, its
   scale error and noise as in the kinematic engine); integrated in the odom frame, turning about base_link or, with
   ``BaseParams.odom_rotation_center_x``, about that point (as the p2os driver with the same parameter).
   Wheel slip and skid become odometry error by themselves: no noise is injected into the wheels;
4. a contact between the robot's hull and an obstacle geom is a collision, counted once per contact
   episode (a new one after ``collision_debounce`` without contact), as the kinematic engine counts.
"""

from __future__ import annotations

import math

import numpy as np

from common.geometry import Pose2D, pivoted
from robot_side.sim.base import BaseParams, CommandedBase, _arc, _limit, _toward
from robot_side.sim.mujoco_scene import add_obstacles, build_scene, import_mujoco, rebuild, wheel_loop_gain
from robot_side.sim.physics_params import PhysicsParams
from robot_side.sim.robot_bodies import body_for
from robot_side.sim.world import World
from robot_side.sim.world_shapes import Box

__all__ = ["MujocoBase", "WheelSpeedLoop"]


class WheelSpeedLoop:
    """PI speed control of the wheel motors, as the robots' motor controllers close it. The proportional
    part is the MuJoCo velocity actuator (``wheel_loop_gain``, torque-limited, integrated implicitly);
    the integral part shifts its set point by ∫error / tau (tau 0.05 s, our choice: no maker publishes
    one), so a wheel holds its commanded speed under the scrubbing load of a skid-steer turn, up to the
    motor's torque limit. The integral is held while the torque is clipped (anti-windup)."""

    def __init__(self, n: int, kp: float, tau: float = 0.05, torque_max: float | None = None):
        self.kp, self.tau = kp, tau
        self.tmax = math.inf if torque_max is None else torque_max
        self.integral = np.zeros(n)

    def set_point(self, target: np.ndarray, speed: np.ndarray, dt: float) -> np.ndarray:
        """The velocity actuators' ctrl: target + ∫(target - speed) dt / tau."""
        err = target - speed
        integral = self.integral + err * dt
        free = np.abs(self.kp * (err + integral / self.tau)) < self.tmax
        self.integral[free] = integral[free]
        return target + self.integral / self.tau


class MujocoBase(CommandedBase):
    """A robot body on MuJoCo with ground truth (world frame) and wheel odometry (odom frame)."""

    def __init__(self, world: World, params: BaseParams, physics: PhysicsParams, start: Pose2D | None = None):
        self.mj = import_mujoco()
        self.world, self.p, self.phys = world, params, physics
        self.body = body_for(params.model)
        s = start if start is not None else world.start
        self.scene = build_scene(world, self.body, physics, s.x, s.y, s.theta)
        self._index()
        b = self.body
        self.loop = WheelSpeedLoop(len(b.wheels), wheel_loop_gain(b), torque_max=b.wheel_torque_max)
        self.motors_enabled = params.motors_enabled
        self.ref_v = self.ref_w = 0.0  # the controller's ramped command
        self.v = self.w = 0.0          # odometry's velocities
        self.collisions = 0
        self.contact: tuple[float, float] | None = None
        self.in_contact = False
        self._last_contact_time = -math.inf
        self.rng = np.random.default_rng(physics.seed)
        self._gyro_bias_sample, self._gyro_next = 0.0, -math.inf
        self._settle()
        self.odom = Pose2D(0.0, 0.0, self.pose.theta) if params.odom_start_yaw_from_world else Pose2D()

    def _index(self) -> None:
        sc, m = self.scene, self.scene.model
        self._robot_geom = np.zeros(m.ngeom, bool)
        self._robot_geom[list(sc.robot_geoms)] = True
        self._obst_geom = np.zeros(m.ngeom, bool)
        self._obst_geom[list(sc.obstacle_geoms)] = True
        self._free_dof = int(m.jnt_dofadr[m.body_jntadr[sc.base_body]])
        self._wheel_dofs = np.array(sc.wheel_joints)
        self._left, self._right = np.array(sc.left), np.array(sc.right)
        side = np.zeros(len(self.body.wheels))
        side[self._left] = -1.0
        side[self._right] = 1.0
        self._side = side  # wheel speed = (v + side * w s/2) / r

    def _settle(self) -> None:
        m, d = self.scene.model, self.scene.data
        ts = m.opt.timestep
        for _ in range(round(self.phys.settle_time / ts)):  # motors holding the wheels still
            d.ctrl[:] = self.loop.set_point(np.zeros(len(self._wheel_dofs)), d.qvel[self._wheel_dofs], ts)
            self.mj.mj_step(m, d)

    # ------------------------------------------------------------------ state
    @property
    def pose(self) -> Pose2D:
        """Ground truth: base_link projected onto the floor, in the world frame."""
        d, b = self.scene.data, self.scene.base_body
        x, y = d.xpos[b][:2]
        xm = d.xmat[b]
        return Pose2D(float(x), float(y), math.atan2(xm[3], xm[0]))

    def frame3d(self) -> tuple[np.ndarray, np.ndarray]:
        """(position (3,), rotation (3, 3)) of base_link in the world: pitch and roll included."""
        d, b = self.scene.data, self.scene.base_body
        return d.xpos[b].copy(), d.xmat[b].reshape(3, 3).copy()

    def true_twist(self) -> tuple[float, float]:
        """Forward speed and yaw rate of the body (world frame, ground truth)."""
        d = self.scene.data
        rot = d.xmat[self.scene.base_body].reshape(3, 3)
        lin = d.qvel[self._free_dof:self._free_dof + 3]        # world frame for a free joint
        ang = rot @ d.qvel[self._free_dof + 3:self._free_dof + 6]  # body frame -> world
        return float(lin[0] * rot[0, 0] + lin[1] * rot[1, 0]), float(ang[2])

    # ------------------------------------------------------------------ inputs
    def set_motors(self, enabled: bool) -> None:
        self.motors_enabled = bool(enabled)
        if not enabled:
            self.ref_v = self.ref_w = 0.0

    def add_box(self, box: Box) -> None:
        """A static box appears (the world's grid has it already): the model is recompiled, state kept."""
        self.scene = rebuild(self.scene, self.body, lambda mj, spec: add_obstacles(mj, spec, [box], self.phys,
                                                                                   self.scene.model.nbody))
        self._index()

    # ------------------------------------------------------------------ physics
    def step(self, dt: float, now: float) -> None:
        """Advance ``dt`` seconds in physics steps; ``now`` is the clock at the end (cmd_vel timeout)."""
        if dt <= 0:
            return
        m, d = self.scene.model, self.scene.data
        ts = m.opt.timestep
        n = max(1, round(dt / ts))
        for i in range(n):
            t = now - dt + (i + 1) * ts
            d.ctrl[:] = self.loop.set_point(self._wheel_targets(t, ts), d.qvel[self._wheel_dofs], ts)
            self.mj.mj_step(m, d)
            self._odometry(t, ts)
            self._contacts(t)

    def _wheel_targets(self, t: float, ts: float) -> np.ndarray:
        p, b = self.p, self.body
        if not self.motors_enabled:
            self.ref_v = self.ref_w = 0.0
            return np.zeros(len(b.wheels))
        tv, tw = self.commanded(t)
        self.ref_v = _toward(self.ref_v, tv, _limit(self.ref_v, tv, p.acc_lim_x, p.decel_lim_x) * ts)[0]
        self.ref_w = _toward(self.ref_w, tw, _limit(self.ref_w, tw, p.acc_lim_th, p.decel_lim_th) * ts)[0]
        half = b.wheel_separation * b.wheel_separation_multiplier / 2
        speeds = (self.ref_v + self._side * self.ref_w * half) / b.wheels[0].radius
        return np.clip(speeds, -b.wheel_speed_max, b.wheel_speed_max)

    def _odometry(self, t: float, ts: float) -> None:
        b, d = self.body, self.scene.data
        q = d.qvel[self._wheel_dofs]
        r = b.wheels[0].radius
        wl, wr = float(q[self._left].mean()), float(q[self._right].mean())
        self.v = r * (wl + wr) / 2
        if b.heading_from_gyro:
            if t >= self._gyro_next:  # a new gyro sample
                self._gyro_next = t + 1.0 / b.gyro_rate
                self._gyro_bias_sample = b.gyro_noise * float(self.rng.standard_normal()) if b.gyro_noise else 0.0
            self.w = self.true_twist()[1] + self._gyro_bias_sample
        elif self.p.gyro:  # the P3-AT's optional gyro (BaseParams.gyro: ARIA's figures)
            p, w = self.p, self.true_twist()[1]
            var = p.gyro_noise ** 2 * ts + p.gyro_turn_noise ** 2 * abs(w) * ts
            self.w = (1.0 + p.gyro_scale_error) * w + math.sqrt(var) / ts * float(self.rng.standard_normal())
        else:
            self.w = r * (wr - wl) / (b.wheel_separation * b.wheel_separation_multiplier)
        self.odom = self.odom.compose(pivoted(_arc(self.v * ts, self.w * ts), self.p.odom_rotation_center_x))

    def _contacts(self, t: float) -> None:
        d = self.scene.data
        touching = False
        if d.ncon:
            g = d.contact.geom[:d.ncon]
            hit = (self._robot_geom[g[:, 0]] & self._obst_geom[g[:, 1]]) | \
                  (self._robot_geom[g[:, 1]] & self._obst_geom[g[:, 0]])
            if hit.any():
                touching = True
                pts = d.contact.pos[:d.ncon][hit]
                self.contact = (float(pts[:, 0].mean()), float(pts[:, 1].mean()))
                if t - self._last_contact_time > self.p.collision_debounce:
                    self.collisions += 1
                self._last_contact_time = t
        self.in_contact = touching
