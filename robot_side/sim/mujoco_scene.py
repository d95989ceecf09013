"""A world and a robot body as a MuJoCo model (``mujoco.MjSpec``). Pure: no bus.

Geom groups (what the sensors' rays and the collision count look at):
  0  obstacles: walls, boxes, cylinders (static, or free bodies for ``movable`` boxes)
  1  the robot: hull boxes, wheels, casters (never seen by its own sensors)
  2  the floor plane

Contacts: wheels and casters touch the floor only (contype / conaffinity bits), the hull touches
obstacles, obstacles touch the floor and each other; the robot's parts never touch each other.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from robot_side.sim.physics_params import MUJOCO_INSTALL, PhysicsParams
from robot_side.sim.robot_bodies import RobotBody
from robot_side.sim.world import World
from robot_side.sim.world_shapes import Box, Cylinder

__all__ = ["import_mujoco", "Scene", "build_scene", "add_obstacles", "rebuild", "wheel_loop_gain", "OBSTACLE_GROUP",
           "ROBOT_GROUP", "FLOOR_GROUP"]

OBSTACLE_GROUP, ROBOT_GROUP, FLOOR_GROUP = 0, 1, 2
# contype / conaffinity bits: two geoms touch when one's contype shares a bit with the other's conaffinity
_FLOOR, _OBST, _HULL, _WHEEL = 1, 2, 4, 8


def import_mujoco():
    """The ``mujoco`` module, or a RuntimeError whose one line says how to install it."""
    try:
        import mujoco
    except ImportError as e:
        raise RuntimeError(f"the mujoco package is not installed (engine 'mujoco' needs it): {MUJOCO_INSTALL}") from e
    return mujoco


@dataclass
class Scene:
    model: Any             # mujoco.MjModel (mujoco ships no type stubs)
    data: Any              # mujoco.MjData
    spec: Any              # mujoco.MjSpec (kept for recompiling when a box is added)
    base_body: int         # body id of the robot
    wheel_joints: list[int]      # qvel address per wheel, in body.wheels order
    left: list[int]        # indices into wheels of the left side (y > 0)
    right: list[int]
    robot_geoms: set[int]
    obstacle_geoms: set[int]


def _quat_z(yaw: float) -> list[float]:
    return [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]


def add_obstacles(mj, spec, shapes: list[Box], p: PhysicsParams, first: int = 0) -> None:
    """Geoms for ``shapes`` (movable boxes become free bodies ``movable<first + i>``)."""
    fr = [p.obstacle_friction, 0.005, 0.0001]
    for i, s in enumerate(shapes, first):
        h = s.height
        kw = dict(group=OBSTACLE_GROUP, contype=_OBST, conaffinity=_OBST | _HULL | _FLOOR, friction=fr,
                  rgba=[0.6, 0.45, 0.3, 1.0])
        if isinstance(s, Cylinder):
            kw.update(type=mj.mjtGeom.mjGEOM_CYLINDER, size=[s.sx / 2, h / 2, 0.0])
        else:
            kw.update(type=mj.mjtGeom.mjGEOM_BOX, size=[s.sx / 2, s.sy / 2, h / 2])
        if s.movable:
            body = spec.worldbody.add_body(name=f"movable{i}", pos=[s.cx, s.cy, h / 2], quat=_quat_z(s.yaw))
            body.add_freejoint()
            body.add_geom(mass=s.mass, **kw)
        else:
            spec.worldbody.add_geom(pos=[s.cx, s.cy, h / 2], quat=_quat_z(s.yaw), **kw)


def _add_robot(mj, spec, body: RobotBody, p: PhysicsParams, x: float, y: float, yaw: float):
    base = spec.worldbody.add_body(name="base_link", pos=[x, y, 0.0], quat=_quat_z(yaw))
    base.add_freejoint()
    base.add_site(name="base_link")
    base.mass, base.ipos, base.inertia, base.explicitinertial = body.mass, list(body.com), list(body.inertia), True
    z0, z1 = body.hull_z
    for cx, cy, sx, sy in body.hull:
        base.add_geom(type=mj.mjtGeom.mjGEOM_BOX, size=[sx / 2, sy / 2, (z1 - z0) / 2],
                      pos=[cx, cy, (z0 + z1) / 2], group=ROBOT_GROUP, contype=_HULL, conaffinity=_OBST,
                      mass=0.0, rgba=[0.2, 0.2, 0.2, 1.0], friction=[p.obstacle_friction, 0.005, 0.0001])
    joints = []
    for k, w in enumerate(body.wheels):
        wb = base.add_body(name=f"wheel{k}", pos=[w.x, w.y, w.radius])
        wb.mass, wb.ipos, wb.inertia, wb.explicitinertial = w.mass, [0.0, 0.0, 0.0], list(w.inertia), True
        wb.add_joint(name=f"wheel{k}", type=mj.mjtJoint.mjJNT_HINGE, axis=[0.0, 1.0, 0.0],
                     armature=body.wheel_armature, damping=[body.wheel_damping, 0.0, 0.0],
                     frictionloss=body.wheel_frictionloss)
        # a cylinder lying along y (its axis is the geom's z, turned onto y)
        wb.add_geom(type=mj.mjtGeom.mjGEOM_CYLINDER, size=[w.radius, w.width / 2, 0.0],
                    quat=[math.sqrt(0.5), math.sqrt(0.5), 0.0, 0.0], group=ROBOT_GROUP, contype=_WHEEL,
                    conaffinity=_FLOOR, mass=0.0, friction=[p.friction, 0.005, 0.0001], rgba=[0.1, 0.1, 0.1, 1])
        joints.append(f"wheel{k}")
        # the motor and the proportional part of its speed loop: torque = kp (ctrl - speed), clipped to the
        # motor's limit where one is known; MuJoCo integrates it implicitly (stable for light wheels)
        act = spec.add_actuator(name=f"wheel{k}", target=f"wheel{k}", trntype=mj.mjtTrn.mjTRN_JOINT)
        act.set_to_velocity(kv=wheel_loop_gain(body))
        if body.wheel_torque_max is not None:
            act.forcelimited, act.forcerange = True, [-body.wheel_torque_max, body.wheel_torque_max]
    for k, (cx, cy, r) in enumerate(body.casters):
        base.add_geom(name=f"caster{k}", type=mj.mjtGeom.mjGEOM_SPHERE, size=[r, 0, 0],
                      pos=[cx, cy, r + body.caster_clearance], group=ROBOT_GROUP, contype=_WHEEL,
                      conaffinity=_FLOOR, mass=0.0, friction=[0.0, 0.0, 0.0], condim=1)
    return joints


def wheel_loop_gain(body: RobotBody) -> float:
    """Proportional gain (N m s/rad) of a wheel's speed loop. No maker publishes its motor drivers' gains:
    1 rad/s of speed error asks for the torque that accelerates the whole robot at 1 g, so the loop is
    stiff next to the tyres' grip and the motor's torque limit clips it where one is known."""
    return body.total_mass * 9.81 * body.wheels[0].radius / len(body.wheels)


def build_scene(world: World, body: RobotBody, p: PhysicsParams, x: float, y: float, yaw: float) -> Scene:
    mj = import_mujoco()
    spec = mj.MjSpec()
    spec.option.timestep = p.timestep
    spec.option.integrator = mj.mjtIntegrator.mjINT_IMPLICITFAST
    spec.worldbody.add_geom(name="floor", type=mj.mjtGeom.mjGEOM_PLANE, size=[0.0, 0.0, 1.0], group=FLOOR_GROUP,
                            contype=_FLOOR, conaffinity=_WHEEL | _OBST, friction=[p.friction, 0.005, 0.0001])
    add_obstacles(mj, spec, world.solid_boxes(), p)
    joints = _add_robot(mj, spec, body, p, x, y, yaw)
    model = spec.compile()
    return _scene(mj, model, mj.MjData(model), spec, body, joints)


def _scene(mj, model, data, spec, body: RobotBody, joints: list[str]) -> Scene:
    base = model.body("base_link").id
    robot_bodies = {base} | {model.body(f"wheel{k}").id for k in range(len(body.wheels))}
    robot = {g for g in range(model.ngeom) if model.geom_bodyid[g] in robot_bodies}
    obstacles = {g for g in range(model.ngeom) if model.geom_group[g] == OBSTACLE_GROUP and g not in robot}
    return Scene(model, data, spec, base, [int(model.jnt_dofadr[model.joint(j).id]) for j in joints],
                 [k for k, w in enumerate(body.wheels) if w.y > 0], [k for k, w in enumerate(body.wheels) if w.y < 0],
                 robot, obstacles)


def rebuild(scene: Scene, body: RobotBody, add) -> Scene:
    """Recompile after ``add(mujoco, spec)`` changed the spec; the state (pose, speeds) carries over."""
    mj = import_mujoco()
    add(mj, scene.spec)
    model, data = scene.spec.recompile(scene.model, scene.data)
    mj.mj_forward(model, data)  # place the new geoms (rays and contacts read their world poses)
    return _scene(mj, model, data, scene.spec, body, [f"wheel{k}" for k in range(len(body.wheels))])
