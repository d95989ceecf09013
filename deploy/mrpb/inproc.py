"""An MRPB case in one process, faster than real time (``bench/mrpb.py --mode fast``): the robot and
master files on ``deploy.stack.inproc.InProcessStack`` (TF exact, as fake_localization gives it), the
robot at the case's start in the environment's world, the master on the map the robot is given."""

from __future__ import annotations

import time

import numpy as np

from common.geometry import Pose2D
from common.messages import GoalStatus
from deploy.mrpb.cases import TIME_LIMIT_S, Case, Result
from deploy.stack.inproc import InProcessStack
from master_side.move_base.state_machine import State


def run_case_fast(case: Case, robot_config, master_config, seed: int = 0,
                  time_limit_s: float = TIME_LIMIT_S, engine: str | None = None,
                  master_set: tuple[str, ...] = (), robot_set: tuple[str, ...] = ()) -> Result:
    """``engine``: the simulator's (None: the robot file's); ``master_set`` / ``robot_set``: ``zenav master
    --set`` / ``zenav robot --set`` values."""
    wall0 = time.perf_counter()
    stack = InProcessStack(case.world_file, robot_config, master_config, seed=seed, start=case.start,
                           map_file=case.map_file, engine=engine, master_set=master_set, robot_set=robot_set)
    sim = stack.sim
    goal = stack.frame_from_world(stack.global_frame).compose(Pose2D(*case.goal))
    t0, hits0 = sim.time, sim.base.collisions
    stack.machine.set_goal(case.name, goal, t0)
    rows = []
    status, reason = "timeout", f"not reached within {time_limit_s:g} s"
    while sim.time - t0 < time_limit_s:
        d = stack.step()
        if sim.base.collisions != hits0:
            c = sim.base.contact
            status, reason = "collision", f"contact at ({c[0]:.2f}, {c[1]:.2f})" if c else "contact"
            break
        if d is None:
            continue
        p = sim.base.pose
        rows.append((sim.time, p.x, p.y, p.theta, sim.base.v, sim.base.w))
        if stack.machine.state is State.IDLE:
            ok = stack.machine.status == GoalStatus.SUCCEEDED
            status, reason = ("success", "") if ok else ("aborted", stack.machine.reason)
            break
    return Result(case, status, reason, np.array(rows, float).reshape(-1, 6), np.array(stack.cycle_ms),
                  time.perf_counter() - wall0)
