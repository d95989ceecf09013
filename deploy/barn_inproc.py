"""BARN in one process, faster than real time: the simulator, both costmaps and move_base stepped on
the simulated clock, no bus (``bench/barn.py --mode fast``).

The pieces are the ones the real nodes run, built from the same files: the robot YAML's simulator
node mapping (``robot_side.sim.node.load``), the master YAML's costmap and move_base node mappings
(``load_costmap_files``, ``load_move_base_config``). What the bus and the processes would add is
modelled: sensor readings reach the costmaps at once (observation_persistence 0 keeps the newest), the
controller reads the live local costmap (as ROS's in-process costmap), the global planner, which runs on
its own thread in move_base, here plans at ``plan_hz`` of simulated time (at most the configured
planner_frequency); TF is exact (odometry for ``odom``, ground truth for ``map``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from common.config import read_yaml
from common.geometry import Pose2D
from common.messages import Twist
from deploy import barn
from master_side.costmap.layered import LayeredCostmap
from master_side.costmap.observation import scan_to_points
from master_side.costmap.obstacle_layer import ObstacleLayer
from master_side.costmap.params import load_costmap_files
from master_side.move_base.config import load_move_base_config
from master_side.move_base.controller import LocalController
from master_side.move_base.planner_thread import ImmediatePlanner
from master_side.move_base.recovery import recoveries_from_params
from master_side.move_base.state_machine import MoveBaseMachine, State
from master_side.planning.navfn import NavFn
from robot_side.sim import node as sim_node

REPO = Path(__file__).resolve().parents[1]
ROBOT_CONFIG = REPO / "robot_side" / "config" / "jackal_sim.yaml"
MASTER_CONFIG = REPO / "master_side" / "config" / "jackal_barn.yaml"


@dataclass
class Outcome:
    run: barn.Run
    cycle_ms: np.ndarray  # wall time of each control cycle, without the global planning in it
    plan_ms: np.ndarray  # wall time of each global plan
    wall_s: float
    sim_s: float
    final_state: str
    events: list[str] = field(default_factory=list)


class _Costmap:
    def __init__(self, cfg):
        self.cfg, self.lcm = cfg, LayeredCostmap.from_config(cfg)
        self.frame = cfg.costmap.global_frame
        f = cfg.costmap.update_frequency
        self.period = 1.0 / f if f > 0 else math.inf
        self.next = 0.0

    def grid(self):
        m = self.lcm.master
        return m.data, m.resolution, (m.origin_x, m.origin_y)


class InProcessStack:
    def __init__(self, world_path: str | Path, robot_config: str | Path = ROBOT_CONFIG,
                 master_config: str | Path = MASTER_CONFIG, plan_hz: float = 5.0, seed: int = 0,
                 engine: str | None = None, friction: float | None = None):
        robot_config, master_config = Path(robot_config), Path(master_config)
        sim_cfg = dict(read_yaml(robot_config)["platform"]["sim"]["params"])
        sim_cfg["world"] = str(world_path)
        sim_cfg.setdefault("sim", {})
        sim_cfg["sim"] = {**sim_cfg["sim"], "seed": seed}
        if engine is not None:
            sim_cfg["engine"] = engine
        if friction is not None:
            sim_cfg["physics"] = {**(sim_cfg.get("physics") or {}), "friction": friction}
        _, self.sim, _ = sim_node.load(sim_cfg, str(robot_config))
        nodes = read_yaml(master_config)["nodes"]
        self.costmaps: dict[str, _Costmap] = {}
        mb_cfg = None
        for entry in nodes.values():
            params = entry.get("params") or {}
            if entry.get("module") == "master_side.costmap.node":
                base = master_config.parent
                cfg = load_costmap_files(base / params["common"], base / params["specific"], name=params.get("name"))
                self.costmaps[cfg.name] = _Costmap(cfg)
            elif entry.get("module") == "master_side.move_base.node":
                mb_cfg = load_move_base_config(params, str(master_config))
        if mb_cfg is None or set(self.costmaps) != {"global_costmap", "local_costmap"}:
            raise ValueError(f"{master_config}: needs global_costmap, local_costmap and move_base nodes")
        self.mb = mb_cfg
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
        self._start_odom_from_world = self.sim.base.pose.compose(self.sim.base.odom.inverse())

    # -- frames -------------------------------------------------------------------------------------
    def pose_in(self, frame: str) -> Pose2D:
        """The robot in ``frame`` as TF would give it: odometry in odom, ground truth in map."""
        return self.sim.base.odom if frame == "odom" else self.sim.base.pose

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

    def _observe(self) -> None:
        scan = self.sim.scan()
        lp = self.sim.laser.p
        topic = lp.topic.strip("/")
        pts_laser = scan_to_points(scan)
        mount = Pose2D(lp.x, lp.y, lp.yaw)
        for cm in self.costmaps.values():
            robot = self.pose_in(cm.frame)
            sensor = robot.compose(mount)
            xy = sensor.apply(pts_laser[:, :2]) if len(pts_laser) else np.zeros((0, 2))
            pts = np.column_stack((xy, np.full(len(xy), lp.z)))
            origin = np.array([sensor.x, sensor.y, lp.z])
            for layer in cm.lcm.layers:
                if isinstance(layer, ObstacleLayer):
                    for name, buf in layer.buffers.items():
                        if (buf.params.topic or name).strip("/") == topic and buf.params.data_type == "LaserScan":
                            layer.add_observation(name, pts, origin, self.sim.time)

    # -- the run -------------------------------------------------------------------------------------
    def run(self, world: int, goal_world: tuple[float, float], goal_yaw: float = 0.0,
            start_limit: float = 30.0) -> Outcome:
        """Drive to ``goal_world`` until BARN's verdict (or until the robot has not started to move
        ``start_limit`` s after the goal, or move_base gave up: both time out)."""
        sim, wall0 = self.sim, time.perf_counter()
        gf = self.mb.global_frame or "odom"
        goal = self.frame_from_world(gf).compose(Pose2D(goal_world[0], goal_world[1], goal_yaw))
        self.machine.set_goal("barn", goal, sim.time)
        trace, hits, cycles, events = [], [], [], []
        next_control, collisions = 0.0, sim.base.collisions
        start = sim.base.pose
        t_moved = None
        while True:
            due = sim.step()
            t = sim.time
            if "laser" in due:
                self._observe()
            for cm in self.costmaps.values():
                if t + 1e-9 >= cm.next:
                    cm.next = t + cm.period
                    cm.lcm.update_map(self.pose_in(cm.frame))
            if t + 1e-9 >= next_control:
                next_control = t + self.control_period
                c0, planned = time.perf_counter(), sum(self.plan_ms)
                lf = self.mb.local_frame
                local = self.costmaps["local_costmap"]
                self.controller.update(self.pose_in(lf), self.frame_from_world(lf).compose(
                    self.frame_from_world(gf).inverse()), local.grid())
                d = self.machine.tick(t, self.pose_in(gf), (sim.base.v, 0.0, sim.base.w))
                sim.cmd_vel(Twist.planar(d.cmd[0], d.cmd[2]))
                cycles.append((time.perf_counter() - c0) * 1e3 - (sum(self.plan_ms) - planned))
                if d.event:
                    events.append(f"{t:7.2f} {d.event}")
            if sim.base.collisions != collisions:
                collisions = sim.base.collisions
                hits.append(t)
            pose = sim.base.pose
            trace.append((t, pose.x, pose.y))
            if t_moved is None and pose.distance(start) >= barn.MOTION_START_M:
                t_moved = t
            near = math.hypot(pose.x - goal_world[0], pose.y - goal_world[1]) <= barn.GOAL_RADIUS_M
            over = (t - (t_moved if t_moved is not None else 0.0)) >= barn.TIME_LIMIT_S
            gave_up = self.machine.state is State.IDLE
            if hits or near or over or gave_up or (t_moved is None and t > start_limit):
                break
        if not (hits or near or over):
            # move_base gave up or the robot never started: it stays where it is until the time limit
            end = (t_moved if t_moved is not None else trace[0][0]) + barn.TIME_LIMIT_S
            trace.append((max(end, trace[-1][0]), trace[-1][1], trace[-1][2]))
        run = barn.judge(world, np.array(trace), hits)
        return Outcome(run, np.array(cycles), np.array(self.plan_ms), time.perf_counter() - wall0, sim.time,
                       self.machine.state.value + (f" ({self.machine.reason})" if self.machine.reason else ""),
                       events)


def run_world(world: int, directory: str | Path, **kw) -> Outcome:
    """Write world ``world`` into ``directory`` and run it in process."""
    path = barn.write_world(world, directory)
    stack = InProcessStack(path, **kw)
    from robot_side.worlds.barn import GOAL
    return stack.run(world, GOAL)
