"""A robot and its master in one process, faster than real time: the simulator, both costmaps and
move_base stepped on the simulated clock, no bus (``bench/barn.py --mode fast`` through
``deploy.barn.inproc``, the in-process navigation tests).

The pieces are the ones the real nodes run, built from the same files read by the same loaders: the
robot YAML through ``robot_side.agent.load`` (its simulator node, ``robot_side.sim.node.load``, and its
depth_to_scan node: a depth camera's scan as ``robot_side.depth.depth_to_scan_node`` makes it), the
master YAML through ``master_side.agent.load`` (its map_server, costmap and move_base nodes:
``map_server_node.load``, ``load_costmap_files``, ``load_move_base_config``). What the bus and the
processes would add is modelled: sensor readings reach the costmaps at once, the controller reads the
live local costmap (as ROS's in-process costmap), the global planner, which runs on its own thread in
move_base, here plans at ``plan_hz`` of simulated time (at most the configured planner_frequency); TF is
exact (odometry for ``odom``, ground truth for ``map``, as fake_localization gives it). Left out: the
robot-side collision monitor (it only acts on commands that would reach an obstacle) and AMCL (the
known-map configs localise with fake_localization).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from common.config import strip_frame
from common.geometry import Pose2D
from common.launch import Launch
from common.messages import LaserScan, Twist
from master_side import agent as master_agent
from master_side.costmap.layered import LayeredCostmap
from master_side.costmap.observation import scan_to_points
from master_side.costmap.obstacle_layer import ObstacleLayer
from master_side.costmap.params import load_costmap_files
from master_side.costmap.static_layer import StaticLayer
from master_side.mapping import map_server_node
from master_side.move_base.config import load_move_base_config
from master_side.move_base.controller import LocalController
from master_side.move_base.planner_thread import ImmediatePlanner
from master_side.move_base.recovery import recoveries_from_params
from master_side.move_base.state_machine import MoveBaseMachine, State
from master_side.planning.navfn import NavFn
from robot_side import agent as robot_agent
from robot_side.depth.depth_to_scan import DepthToScan, DepthToScanParams
from robot_side.depth.depth_to_scan_node import DepthToScanTopics
from robot_side.depth.node_util import split_params
from robot_side.sim import node as sim_node


@dataclass
class GoalOutcome:
    """One goal driven to its end (``InProcessStack.goto``)."""
    status: int  # GoalStatus: SUCCEEDED, ABORTED, or ACTIVE when the time limit came first
    reason: str
    truth: Pose2D  # ground truth once the base stood still
    sim_s: float  # simulated time from the goal to move_base's result
    cmds: list[tuple[float, float, float]]  # (sim time, v, w) of each control cycle
    distances: list[tuple[float, float]]  # (sim time, xy distance to the goal) of each control cycle
    collisions: int  # new collisions during the goal
    goal_offset_m: float  # how far navfn moved the goal (0 for a free goal)


@dataclass
class _ScanSource:
    """A scan the robot publishes: the simulator's laser, or a depth camera's image through depth_to_scan."""
    sensor: str  # the simulator's name for it (its step() reports it due)
    topic: str
    read: Callable[[], LaserScan]
    mount: Pose2D  # the scan's frame in base_link (planar part)
    z: float


def _scan_sources(sim, robot: Launch, source: str) -> list[_ScanSource]:
    out = []
    if sim.laser is not None:
        lp = sim.laser.p
        out.append(_ScanSource("laser", lp.topic.strip("/"), sim.scan, Pose2D(lp.x, lp.y, lp.yaw), lp.z))
    if sim.camera is not None:
        cp = sim.camera.p  # base_link -> the depth frame is the rendered mount (robot_side.sim.mounts_node)
        for e in robot.entries:
            if e.opts.module == "robot_side.depth.depth_to_scan_node":
                topics, params = split_params(e.params, source, DepthToScanTopics, DepthToScanParams)
                out.append(_ScanSource("depth_camera", topics.scan_topic.strip("/"),
                                       _depth_scan(sim, DepthToScan(params)), Pose2D(cp.x, cp.y, cp.yaw), cp.z))
    if not out:
        raise ValueError(f"{source}: the simulated robot publishes no scan (a laser, or a depth camera with a "
                         "depth_to_scan node)")
    return out


def _depth_scan(sim, conv: DepthToScan) -> Callable[[], LaserScan]:
    """The simulator's latest depth image through ``conv``, read when called."""
    return lambda: conv.convert(*sim.depth_frame())


class _Costmap:
    def __init__(self, cfg):
        self.cfg, self.lcm = cfg, LayeredCostmap.from_config(cfg)
        self.frame = strip_frame(cfg.costmap.global_frame)
        f = cfg.costmap.update_frequency
        self.period = 1.0 / f if f > 0 else math.inf
        self.next = 0.0

    def grid(self):
        """What the costmap node publishes (unseen cells at ``unseen_cost`` when it is set)."""
        m, unseen = self.lcm.master, self.cfg.costmap.unseen_as
        return m.data if unseen is None else m.published(unseen), m.resolution, (m.origin_x, m.origin_y)


class InProcessStack:
    def __init__(self, world_path: str | Path, robot_config: str | Path,
                 master_config: str | Path, plan_hz: float = 5.0, seed: int = 0,
                 engine: str | None = None, friction: float | None = None,
                 start: tuple[float, float, float] | None = None, map_file: str | Path | None = None,
                 master_set: tuple[str, ...] = (), robot_set: tuple[str, ...] = ()):
        """``start``, ``map_file``, ``master_set`` and ``robot_set`` as ``zenav robot --start``, ``zenav master
        --map``, ``zenav master --set NODE.KEY=VALUE`` and ``zenav robot --set NODE.KEY=VALUE``."""
        robot_config, master_config = Path(robot_config), Path(master_config)
        robot = robot_agent.load(str(robot_config), world=str(world_path), engine=engine,  # as the agent reads it
                                 start=list(start) if start is not None else None, sets=robot_set)
        sim_cfg = dict(next(e.params for e in robot.entries if e.opts.module == robot_agent.SIM_MODULE) or {})
        sim_cfg["sim"] = {**(sim_cfg.get("sim") or {}), "seed": seed}
        if friction is not None:
            sim_cfg["physics"] = {**(sim_cfg.get("physics") or {}), "friction": friction}
        _, self.sim, _ = sim_node.load(sim_cfg, str(robot_config))
        self.sources = _scan_sources(self.sim, robot, str(robot_config))
        self.costmaps: dict[str, _Costmap] = {}
        mb_cfg, grid = None, None
        master = master_agent.load(str(master_config), str(map_file) if map_file else None)  # as the agent does
        for assignment in master_set:
            master.set(assignment)
        for entry in master.entries:
            params, source = master.node_params(entry)
            if entry.opts.module == "master_side.costmap.node":
                base = Path(source).parent
                cfg = load_costmap_files(base / params["common"], base / params["specific"], name=params.get("name"))
                self.costmaps[cfg.name] = _Costmap(cfg)
            elif entry.opts.module == "master_side.move_base.node":
                mb_cfg = load_move_base_config(params, source)
            elif entry.opts.module == "master_side.mapping.map_server_node":
                grid, _ = map_server_node.load(params, source)
        if mb_cfg is None or set(self.costmaps) != {"global_costmap", "local_costmap"}:
            raise ValueError(f"{master_config}: needs global_costmap, local_costmap and move_base nodes")
        if grid is not None:  # the map frame is the world's (ground truth); step() places it in rolling ones
            for cm in self.costmaps.values():
                for layer in cm.lcm.layers:
                    if isinstance(layer, StaticLayer):
                        layer.set_map(grid)
        self.mb = mb_cfg
        self.global_frame = strip_frame(mb_cfg.global_frame or "odom")
        self.local_frame = strip_frame(mb_cfg.local_frame)
        p = mb_cfg.params
        self.navfn = NavFn(mb_cfg.navfn)
        self.controller = LocalController(mb_cfg.make_local_planner(), mb_cfg.footprint)
        hz = min(plan_hz, p.planner_frequency) if p.planner_frequency > 0 else 0.0
        self.planner = ImmediatePlanner(self._plan, hz)
        recs = recoveries_from_params(p, mb_cfg.recovery_namespaces, mb_cfg.source, self._clear, self._blocked,
                                      mb_cfg.circumscribed_radius, mb_cfg.rotate)
        self.machine = MoveBaseMachine(p, self.planner, self.controller, recs)
        self.control_period = 1.0 / p.controller_frequency
        self.plan_ms: list[float] = []
        self.cycle_ms: list[float] = []
        self.events: list[str] = []
        self._next_control = 0.0

    # -- frames -------------------------------------------------------------------------------------
    def pose_in(self, frame: str) -> Pose2D:
        """The robot in ``frame`` as TF would give it: odometry in odom, ground truth in map."""
        return self.sim.base.odom if strip_frame(frame) == "odom" else self.sim.base.pose

    def frame_from_world(self, frame: str) -> Pose2D:
        return self.pose_in(frame).compose(self.sim.base.pose.inverse())

    # -- collaborators ------------------------------------------------------------------------------
    def _plan(self, start: Pose2D, goal: Pose2D):
        cm = self.costmaps["global_costmap"]
        grid, res, origin = cm.grid()
        t0 = time.perf_counter()
        path = self.navfn.make_plan(grid, res, origin, start, goal)
        self.plan_ms.append((time.perf_counter() - t0) * 1e3)
        return path, self.navfn.last_goal_used or goal

    def _clear(self, distance: float, which: str = "both") -> None:
        names = ("local_costmap", "global_costmap") if which == "both" else (f"{which}_costmap",)
        for n in names:
            cm = self.costmaps[n]
            pose = self.pose_in(cm.frame)
            if distance > 0:
                cm.lcm.clear_outside(pose, distance)
            else:
                cm.lcm.reset()

    def _blocked(self, pose_global: Pose2D, yaws: np.ndarray) -> bool:
        lp = self.controller.local_pose
        if lp is None:
            return True
        off = lp.theta - pose_global.theta
        return any(self.controller.footprint_blocked(Pose2D(lp.x, lp.y, y + off)) for y in np.asarray(yaws))

    def _observe(self, src: _ScanSource) -> None:
        scan = src.read()
        points: dict[bool, np.ndarray] = {}  # the scan's points in its frame, per inf_is_valid
        for cm in self.costmaps.values():
            sensor = self.pose_in(cm.frame).compose(src.mount)
            origin = np.array([sensor.x, sensor.y, src.z])
            for layer in cm.lcm.layers:
                if not isinstance(layer, ObstacleLayer):
                    continue
                for name, buf in layer.buffers.items():
                    if (buf.params.topic or name).strip("/") != src.topic or buf.params.data_type != "LaserScan":
                        continue
                    iv = buf.params.inf_is_valid
                    pts = points[iv] if iv in points else points.setdefault(iv, scan_to_points(scan, iv))
                    xy = sensor.apply(pts[:, :2]) if len(pts) else np.zeros((0, 2))
                    layer.add_observation(name, np.column_stack((xy, np.full(len(xy), src.z))), origin,
                                          self.sim.time)

    # -- stepping ------------------------------------------------------------------------------------
    def step(self):
        """One simulator step: due readings to the costmaps, due costmap updates, and a control cycle
        when one is due (its move_base Decision is returned, else None)."""
        sim = self.sim
        due = sim.step()
        t = sim.time
        for src in self.sources:
            if src.sensor in due:
                self._observe(src)
        for cm in self.costmaps.values():
            if t + 1e-9 >= cm.next:
                cm.next = t + cm.period
                if cm.lcm.rolling_window:  # static layers follow map -> this frame, as the node does
                    for layer in cm.lcm.layers:
                        if isinstance(layer, StaticLayer):
                            layer.place(self.frame_from_world(cm.frame))
                cm.lcm.update_map(self.pose_in(cm.frame))
        if t + 1e-9 < self._next_control:
            return None
        self._next_control = t + self.control_period
        c0, planned = time.perf_counter(), sum(self.plan_ms)
        lf, gf = self.local_frame, self.global_frame
        self.controller.update(self.pose_in(lf), self.frame_from_world(lf).compose(self.frame_from_world(gf).inverse()),
                               self.costmaps["local_costmap"].grid())
        d = self.machine.tick(t, self.pose_in(gf), (sim.base.v, 0.0, sim.base.w))
        sim.cmd_vel(Twist.planar(d.cmd[0], d.cmd[2]))
        self.cycle_ms.append((time.perf_counter() - c0) * 1e3 - (sum(self.plan_ms) - planned))
        if d.event:
            self.events.append(f"{t:7.2f} {d.event}")
        return d

    def goto(self, goal_world: Pose2D, time_limit_s: float = 120.0, goal_id: str = "goal") -> GoalOutcome:
        """Send ``goal_world`` (a pose in the world = map frame) and step until move_base's result (or
        ``time_limit_s`` of simulated time), then until the base stands still."""
        sim = self.sim
        goal = self.frame_from_world(self.global_frame).compose(goal_world)
        t0, hits0 = sim.time, sim.base.collisions
        self.machine.set_goal(goal_id, goal, t0)
        cmds, dist = [], []
        while sim.time - t0 < time_limit_s:
            d = self.step()
            if d is None:
                continue
            cmds.append((sim.time, d.cmd[0], d.cmd[2]))
            pose = self.pose_in("map")
            dist.append((sim.time, math.hypot(pose.x - goal_world.x, pose.y - goal_world.y)))
            if self.machine.state is State.IDLE:
                break
        t1, status, reason = sim.time, self.machine.status, self.machine.reason
        while (sim.base.v != 0.0 or sim.base.w != 0.0) and sim.time - t1 < 5.0:
            self.step()
        used = self.navfn.last_goal_used
        offset = 0.0 if used is None else math.hypot(used.x - goal.x, used.y - goal.y)
        return GoalOutcome(status, reason, sim.base.pose, t1 - t0, cmds, dist, sim.base.collisions - hits0, offset)
