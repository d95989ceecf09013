"""BARN in one process, faster than real time (``bench/barn.py --mode fast``): the simulated Jackal
and the challenge's master files on ``deploy.stack.inproc.InProcessStack``, each run ended by BARN's
verdict (``deploy.barn.rules``)."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from common.geometry import Pose2D
from deploy.barn import rules as barn
from deploy.stack.inproc import InProcessStack
from master_side.move_base.state_machine import State

REPO = Path(__file__).resolve().parents[2]
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
    trace: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))  # ground truth rows (t, x, y)
    cmds: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))  # move_base's commands rows (t, v, w)


class BarnStack(InProcessStack):
    """An InProcessStack with the BARN files by default and BARN's verdict loop (``run``)."""

    def __init__(self, world_path: str | Path, robot_config: str | Path = ROBOT_CONFIG,
                 master_config: str | Path = MASTER_CONFIG, **kw) -> None:
        super().__init__(world_path, robot_config, master_config, **kw)

    def run(self, world: int, goal_world: tuple[float, float], goal_yaw: float = 0.0,
            start_limit: float = 30.0) -> Outcome:
        """Drive to ``goal_world`` until BARN's verdict (or until the robot has not started to move
        ``start_limit`` s after the goal, or move_base gave up: both time out)."""
        sim, wall0 = self.sim, time.perf_counter()
        goal = self.frame_from_world(self.global_frame).compose(Pose2D(goal_world[0], goal_world[1], goal_yaw))
        self.machine.set_goal("barn", goal, sim.time)
        trace, hits, cmds = [], [], []
        collisions = sim.base.collisions
        start = sim.base.pose
        t_moved = None
        while True:
            d = self.step()
            t = sim.time
            if d is not None:
                cmds.append((t, d.cmd[0], d.cmd[2]))
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
        raw = np.array(trace, float).reshape(-1, 3)
        # move_base gave up or the robot never started: it stays where it is until the time limit
        judged = raw if (hits or near or over) else barn.held_to_time_limit(raw, (start.x, start.y))
        run = barn.judge(world, judged, hits)
        return Outcome(run, np.array(self.cycle_ms), np.array(self.plan_ms), time.perf_counter() - wall0, sim.time,
                       self.machine.state.value + (f" ({self.machine.reason})" if self.machine.reason else ""),
                       list(self.events), raw, np.array(cmds, float).reshape(-1, 3))
