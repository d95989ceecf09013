"""One BARN run over the bus, as a user runs it: `zenav robot` (the simulated Jackal on the world),
`zenav master` and `zenav goal 0 10 0 --frame odom` as separate processes on a private loopback Zenoh
network; the verdict (deploy/barn/rules.py) from the simulator's ``ground_truth`` and ``collision`` topics.

The run ends as BARN's run.py ends it: within 1 m of the goal, at a collision, or 100 s of simulated
time after the start of motion (move_base giving up, or the robot never starting, is a timeout).
"""

from __future__ import annotations

import math
import tempfile
import threading
import time
import uuid
from pathlib import Path

import numpy as np
import yaml

from common.bus import Node
from common.messages import Collision, Costmap, MoveBaseStatus, Odometry, Scalar, Twist
from common.ports import free_port
from deploy.barn import rules as barn
from deploy.stack.process_group import ProcessGroup
from robot_side.worlds.barn import GOAL, GOAL_IN_ODOM, START

REPO = Path(__file__).resolve().parents[2]
ROBOT_CONFIG = REPO / "robot_side" / "config" / "jackal_sim.yaml"
MASTER_CONFIG = REPO / "master_side" / "config" / "jackal_barn.yaml"
STARTUP_S = 120.0  # wall seconds for the agents to come up on a busy machine


class _Recorder:
    """ground_truth / collision / move_base's commands and loop times, recorded by bus callbacks."""

    def __init__(self, node: Node):
        self.lock = threading.Lock()
        self.trace: list[tuple[float, float, float]] = []
        self.collisions: list = []
        self.loop_ms: list[float] = []
        self.cmds: list[tuple[float, float, float]] = []  # (simulated time of the last truth, v, w)
        node.subscribe("ground_truth", Odometry, callback=self._truth, mode="queue")
        node.subscribe("collision", Collision, callback=self._collision, mode="queue")
        node.subscribe("move_base/loop_time", Scalar, callback=self._loop, mode="queue")
        node.subscribe("cmd_vel", Twist, callback=self._cmd, mode="queue")
        self.status = node.subscribe("move_base/status", MoveBaseStatus)
        self.costmaps = [node.subscribe(f"{n}/costmap", Costmap) for n in ("global_costmap", "local_costmap")]

    def _truth(self, m: Odometry) -> None:
        p = m.pose2d
        with self.lock:
            self.trace.append((m.header.stamp, p.x, p.y))

    def _collision(self, m: Collision) -> None:
        with self.lock:
            self.collisions.append(m)

    def _cmd(self, m: Twist) -> None:
        with self.lock:
            self.cmds.append((self.trace[-1][0] if self.trace else 0.0, m.linear.x, m.angular.z))

    def _loop(self, m: Scalar) -> None:
        with self.lock:
            self.loop_ms.append(m.value * 1e3)

    def snapshot(self):
        with self.lock:
            return np.array(self.trace, float).reshape(-1, 3), barn.collision_times(self.collisions)


def _robot_variant(robot_config: Path, work: Path, friction: float | None, seed: int | None) -> Path:
    """A copy of the robot YAML with the simulator's physics.friction and/or sim.seed set."""
    cfg = yaml.safe_load(robot_config.read_text())
    params = cfg["platform"]["sim"]["params"]
    if friction is not None:
        params["physics"] = {**(params.get("physics") or {}), "friction": float(friction)}
    if seed is not None:
        params["sim"] = {**(params.get("sim") or {}), "seed": int(seed)}
    out = work / f"robot_{friction}_{seed}.yaml"
    out.write_text(yaml.safe_dump(cfg, sort_keys=False))
    return out


def _verdict_due(trace: np.ndarray, hits: list[float]) -> bool:
    if len(trace) == 0:
        return False
    if hits:
        return True
    t, x, y = trace[:, 0], trace[:, 1], trace[:, 2]
    if math.hypot(x[-1] - GOAL[0], y[-1] - GOAL[1]) <= barn.GOAL_RADIUS_M:
        return True
    moved = np.flatnonzero(np.hypot(x - START[0], y - START[1]) >= barn.MOTION_START_M)
    return bool(len(moved)) and t[-1] - t[moved[0]] >= barn.TIME_LIMIT_S


def run_world_bus(world: int, workdir: str | Path = "", master_config: str | Path = MASTER_CONFIG,
                  robot_config: str | Path = ROBOT_CONFIG, speed: float = 1.0, echo=None, engine: str | None = None,
                  friction: float | None = None, seed: int | None = None) -> dict:
    """Run world ``world`` over the bus; returns {"run": barn.Run, "cycle_ms": loop times, "note": str,
    "trace": ground truth rows (t, x, y), "cmds": move_base's commands rows (t, v, w)}."""
    master_config, robot_config = Path(master_config).resolve(), Path(robot_config).resolve()
    work = Path(workdir or tempfile.mkdtemp(prefix="zenav-barn-")).resolve() / f"world_{world}"
    work.mkdir(parents=True, exist_ok=True)
    world_file = barn.write_world(world, work)
    if friction is not None or seed is not None:  # a copy of the robot YAML with these set
        robot_config = _robot_variant(robot_config, work, friction, seed)
    robot = f"barn{world}x{uuid.uuid4().hex[:6]}"
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    group = ProcessGroup(robot, endpoint, work)
    node = Node("barn_bench", config=group.hub_config())
    rec = _Recorder(node)
    note = ""
    try:
        group.spawn("robot", ["robot", "--config", str(robot_config), "--world", str(world_file),
                              "--speed", str(speed), *(["--engine", engine] if engine else [])])
        group.spawn("master", ["master", "--config", str(master_config)])
        group.wait("the simulator", lambda: len(rec.trace) > 0, STARTUP_S)
        group.wait("move_base", lambda: rec.status.latest() is not None, STARTUP_S)
        group.wait("the costmaps", lambda: all(c.latest() is not None for c in rec.costmaps), STARTUP_S)
        goal = group.spawn("goal", ["goal", str(GOAL_IN_ODOM[0]), str(GOAL_IN_ODOM[1]), "0", "--frame", "odom",
                                    "--timeout", str(3 * barn.TIME_LIMIT_S / speed)])
        t_goal = time.monotonic()
        while True:
            trace, hits = rec.snapshot()
            if _verdict_due(trace, hits):
                break
            group.check_alive(ignore=("goal",))
            if goal.poll() is not None:
                st = rec.status.latest()
                note = f"zenav goal exited {goal.returncode}: {st.reason if st else ''}"
                break  # move_base gave up (or reached its own goal tolerance short of 1 m: impossible)
            if time.monotonic() - t_goal > 3 * barn.TIME_LIMIT_S / speed + 60:
                note = "no verdict in wall time"
                break
            time.sleep(0.05)
    except RuntimeError as e:
        note = str(e)
    finally:
        group.stop()
        trace, hits = rec.snapshot()
        loop_ms = np.array(rec.loop_ms)
        with rec.lock:
            cmds = np.array(rec.cmds, float).reshape(-1, 3)
        node.close()
    raw_trace = trace
    if len(trace) == 0:
        trace = np.array([[0.0, *START[:2]]])
    run = barn.judge(world, trace if _verdict_due(trace, hits) else barn.held_to_time_limit(trace), hits)
    if echo:
        echo(f"world {world}: {run.status} {run.time_s:.1f} s {note}")
    return {"run": run, "cycle_ms": loop_ms, "note": note if not run.success else "", "trace": raw_trace,
            "cmds": cmds}
