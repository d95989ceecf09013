"""An MRPB case over the bus, as a user runs it: ``zenav robot`` at the case's start in the environment's
world, ``zenav master`` on the map the robot is given (AMCL started at the case's start through
``--set localization.initial_pose_*``, when the master localises with AMCL), the goal sent as
``zenav goal`` sends it; the run judged from the simulator's ``ground_truth`` and ``collision`` topics and
move_base's status, on a private loopback Zenoh network."""

from __future__ import annotations

import tempfile
import threading
import time
import uuid
from pathlib import Path

import numpy as np

from common.bus import Node
from common.messages import GoalStatus, MoveBaseStatus, PoseStamped, Scalar, Twist
from common.ports import free_port
from deploy.mrpb.cases import TIME_LIMIT_S, Case, Result
from deploy.mrpb.contacts import ContactWatch
from deploy.stack.goals import send_goal
from deploy.stack.process_group import ProcessGroup, set_options
from master_side import agent as master_agent

STARTUP_S = 120.0  # wall seconds for the agents to come up on a busy machine
AMCL_MODULE = "master_side.localization.amcl_node"


class _Recorder:
    """Ground truth at each of move_base's commands (a control cycle), contacts (each with a snapshot in
    ``contact_dir``, for ``bench/contacts.py``), loop times, and the localiser's error: each ``amcl_pose``
    against the ground truth of the same moment."""

    def __init__(self, node: Node, contact_dir: Path):
        self.lock = threading.Lock()
        self.rows: list[tuple[float, ...]] = []
        self.contacts = ContactWatch(node, contact_dir)  # it follows the ground truth too
        self.truth = self.contacts.truth
        self.loop_ms: list[float] = []
        self.loc_err: list[float] = []  # metres, one per amcl_pose
        node.subscribe("amcl_pose", PoseStamped, callback=self._located, mode="queue")
        node.subscribe("move_base/loop_time", Scalar, mode="queue",
                       callback=lambda m: self.loop_ms.append(m.value * 1e3))
        node.subscribe("cmd_vel", Twist, callback=self._cmd, mode="queue")
        self.status = node.subscribe("move_base/status", MoveBaseStatus)

    def _cmd(self, _m: Twist) -> None:
        m = self.truth()
        if m is not None:
            p = m.pose2d
            with self.lock:
                self.rows.append((m.header.stamp, p.x, p.y, p.theta, m.twist.linear.x, m.twist.angular.z))

    def _located(self, m: PoseStamped) -> None:
        g = self.truth()
        if g is not None:
            p, q = m.pose.to_pose2d(), g.pose2d
            with self.lock:
                self.loc_err.append(float(np.hypot(p.x - q.x, p.y - q.y)))

    def contact(self) -> tuple[float, float] | None:
        """The first contact's point in the world (None: none yet)."""
        with self.contacts.lock:
            return self.contacts.contacts[0][1:] if self.contacts.contacts else None


def amcl_start_sets(master_config: Path, case: Case) -> list[str]:
    """``NODE.KEY=VALUE`` assignments starting the master's AMCL at the case's start (none for other
    localisers)."""
    launch = master_agent.load(str(master_config))
    return [f"{e.name}.{key}={value}" for e in launch.entries if e.opts.module == AMCL_MODULE
            for key, value in zip(("initial_pose_x", "initial_pose_y", "initial_pose_a"), case.start)]


def run_case_bus(case: Case, robot_config: Path, master_config: Path, workdir: str | Path = "",
                 speed: float = 1.0, time_limit_s: float = TIME_LIMIT_S, engine: str | None = None,
                 master_set: tuple[str, ...] = (), robot_set: tuple[str, ...] = ()) -> Result:
    wall0 = time.perf_counter()
    work = Path(workdir or tempfile.mkdtemp(prefix="zenav-mrpb-")).resolve() / case.name.replace("/", "_")
    work.mkdir(parents=True, exist_ok=True)
    robot = f"mrpb{uuid.uuid4().hex[:6]}"
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    group = ProcessGroup(robot, endpoint, work)
    node = Node("mrpb_bench", config=group.hub_config(), use_sim_time="auto")
    rec = _Recorder(node, work / "contacts")
    status, reason = "timeout", f"not reached within {time_limit_s:g} s"
    cancel = threading.Event()
    try:
        group.spawn("robot", ["robot", "--config", str(robot_config), "--world", str(case.world_file),
                              "--start", *map(str, case.start), "--speed", str(speed),
                              *(["--engine", engine] if engine else []), *set_options(robot_set)])
        group.spawn("master", ["master", "--config", str(master_config), "--map", str(case.map_file),
                               *set_options((*amcl_start_sets(master_config, case), *master_set))])
        group.wait("the simulator", lambda: rec.truth() is not None, STARTUP_S)
        group.wait("move_base", lambda: rec.status.latest() is not None, STARTUP_S)
        answer: list = []
        sender = threading.Thread(target=lambda: answer.append(send_goal(
            node, *case.goal, "map", time_limit_s / speed + 60.0, echo=lambda _s: None, cancel=cancel)),
            daemon=True)
        sender.start()
        t_wall = time.monotonic()
        while True:
            if (c := rec.contact()) is not None:
                status, reason = "collision", f"contact at ({c[0]:.2f}, {c[1]:.2f})"
                break
            if answer:
                code, st = answer[0]
                if st is not None and st.status == GoalStatus.SUCCEEDED:
                    status, reason = "success", ""
                elif st is not None and st.status != GoalStatus.ACTIVE:
                    status, reason = "aborted", st.reason or f"status {st.status}"
                else:
                    reason = f"zenav goal ended with exit code {code}"
                break
            m = rec.truth()
            with rec.lock:
                first = rec.rows[0][0] if rec.rows else None
            if m is not None and first is not None and m.header.stamp - first > time_limit_s:
                break
            group.check_alive()
            if time.monotonic() - t_wall > time_limit_s / speed * 3 + 120:
                reason = "no end in wall time"
                break
            time.sleep(0.05)
    except RuntimeError as e:  # an agent died or never came up
        status, reason = "aborted", str(e)
    finally:
        cancel.set()
        group.stop()
        node.close()  # after the contact callback, and so its snapshot, has finished
    if status == "collision" and (snap := rec.contacts.snapshot_path(rec.contacts.count)) is not None:
        reason += f"; `python bench/contacts.py {snap.parent} --master {master_config}` says why"
    with rec.lock:
        rows = np.array(rec.rows, float).reshape(-1, 6)
        loop = np.array(rec.loop_ms)
        loc = np.array(rec.loc_err)
    return Result(case, status, reason, rows, loop, time.perf_counter() - wall0, loc)
