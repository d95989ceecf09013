"""Helpers for the navigation end-to-end tests: `zenav robot` (simulated P3-AT) + `zenav master` (known map,
DWA or trajectory rollout) as separate process groups on a private loopback Zenoh bus, and a test peer
that sends goals and records ground truth, collisions, cmd_vel and move_base/status."""

from __future__ import annotations

import contextlib
import math
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
import uuid
from pathlib import Path

import psutil
import yaml

from common.launch import absolute_paths
from testkit.wait import free_port, wait_until

REPO = Path(__file__).resolve().parents[1]
MASTER_DIR = REPO / "master_side" / "config"
ROBOT_CONFIG = REPO / "robot_side" / "config" / "p3at_sim.yaml"
WORLDS = REPO / "robot_side" / "worlds"
PLANNERS = {"dwa": MASTER_DIR / "p3at_known_map.yaml",
            "trajectory": MASTER_DIR / "p3at_known_map_trajectory.yaml"}


def world_goals(world: str) -> dict[str, tuple[float, float, float]]:
    data = yaml.safe_load((WORLDS / f"{world}.yaml").read_text())
    return {k: tuple(float(x) for x in v) for k, v in data["goals"].items()}


def absolute_param_paths(cfg: dict, base: Path) -> None:
    """Node parameters naming a file relative to the config's folder ``base`` made absolute (the
    generated config is written elsewhere), as the agents do for ``--set``."""
    for spec in cfg["nodes"].values():
        absolute_paths(spec.get("params") or {}, base)


def master_config_for(planner: str, world: str, tmp: Path, move_base: dict | None = None,
                      navfn: dict | None = None) -> Path:
    """The shipped master YAML for ``planner``. For another world than the room, or with ``move_base`` /
    ``navfn`` parameter overrides, a copy in ``tmp``: relative paths made absolute, ``map:`` pointing at a
    map exported from the world (deploy.stack.world_maps), the overrides merged into move_base's files."""
    src = PLANNERS[planner]
    if world == "room" and not move_base and not navfn:
        return src
    from deploy.stack.world_maps import export_world_map

    cfg = yaml.safe_load(src.read_text())
    absolute_param_paths(cfg, src.parent)
    for spec in cfg["nodes"].values():
        params = spec.get("params") or {}
        if "map" in params and world != "room":
            params["map"] = str(export_world_map(world, tmp / "maps"))
    mb = cfg["nodes"]["move_base"]["params"]
    if move_base:
        mb_file = tmp / "move_base_overrides.yaml"
        mb_file.write_text(yaml.safe_dump({**yaml.safe_load(Path(mb["move_base"]).read_text()), **move_base}))
        mb["move_base"] = str(mb_file)
    if navfn:
        mb["global_planner"] = {"NavfnROS": dict(navfn)}
    out = tmp / f"master_{planner}_{world}.yaml"
    out.write_text(yaml.safe_dump(cfg, sort_keys=False))
    return out


class NavProc:
    """A subprocess in its own session; output to a file; SIGINT then SIGKILL of its process group."""

    def __init__(self, log: Path, argv: list[str], env: dict) -> None:
        self.log_path = log
        with open(log, "wb") as o:
            self.proc = subprocess.Popen(argv, stdout=o, stderr=subprocess.STDOUT, env=env, cwd=REPO,
                                         start_new_session=True)

    def log(self, tail: int = 6000) -> str:
        return self.log_path.read_text(errors="replace")[-tail:]

    def alive(self) -> bool:
        return self.proc.poll() is None

    def children(self) -> list[int]:
        """Pids of the agent's processes: its fork server (common.fork_server) and the node processes
        (each in its own session; forks of the server, or children of the agent when started with
        python -m)."""
        parent: dict[int, int] = {}
        for d in Path("/proc").iterdir():
            if d.name.isdigit():
                with contextlib.suppress(OSError, ValueError, IndexError):
                    parent[int(d.name)] = int((d / "stat").read_text().rsplit(")", 1)[1].split()[1])
        out, level = [], {self.proc.pid}
        while level:
            level = {pid for pid, pp in parent.items() if pp in level}
            out += sorted(level)
        return out

    def child_running(self, module: str) -> int | None:
        """Pid of the agent's node process whose command line runs ``module``."""
        for pid in self.children():
            with contextlib.suppress(OSError):
                argv = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
                if module.encode() in argv and b"common.fork_server" not in argv:
                    return pid
        return None

    def stop(self, timeout: float = 15.0) -> None:
        kids = self.children()
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            with contextlib.suppress(subprocess.TimeoutExpired):
                self.proc.wait(timeout)
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(self.proc.pid, signal.SIGKILL)
        with contextlib.suppress(subprocess.TimeoutExpired):
            self.proc.wait(5)
        # the nodes die with their agent (PDEATHSIG); make sure, by pid, that none is left behind
        deadline = time.monotonic() + 5.0
        while kids and time.monotonic() < deadline:
            kids = [k for k in kids if Path(f"/proc/{k}").exists() and not _zombie(k)]
            time.sleep(0.05)
        for k in kids:
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.kill(k, signal.SIGCONT)
                os.kill(k, signal.SIGKILL)


def _zombie(pid: int) -> bool:
    with contextlib.suppress(OSError):
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] == "Z"
    return True


class NavTimeline:
    """Every message of one topic with its arrival time (monotonic), bounded."""

    def __init__(self, node, topic: str, msg_type, keep: int = 200000) -> None:
        self.items: list[tuple[float, object]] = []
        self.keep = keep
        self.lock = threading.Lock()
        self.sub = node.subscribe(topic, msg_type, callback=self._add, mode="queue", queue_size=100000)

    def _add(self, msg) -> None:
        with self.lock:
            self.items.append((time.monotonic(), msg))
            if len(self.items) > self.keep:
                del self.items[: len(self.items) - self.keep]

    def since(self, t0: float) -> list[tuple[float, object]]:
        with self.lock:
            return [(t, m) for t, m in self.items if t >= t0]

    def last(self):
        with self.lock:
            return self.items[-1][1] if self.items else None


def zenav_command() -> list[str]:
    """The zenav command: the installed entry point, else this checkout's module."""
    exe = shutil.which("zenav")
    return [exe] if exe else [sys.executable, "-m", "deploy.cli"]


class NavStack:
    """One simulated robot + one master on a private bus, and the test's peer on it."""

    def __init__(self, tmp: Path, world: str, planner: str, speed: float = 1.0, move_base: dict | None = None,
                 navfn: dict | None = None) -> None:
        from common.bus import Node
        from common.messages import Collision, MoveBaseStatus, Odometry, Twist
        from common.zenoh_config import BusConfig

        self.world, self.planner, self.speed = world, planner, speed
        self.robot = f"nav{uuid.uuid4().hex[:10]}"
        tmp.mkdir(parents=True, exist_ok=True)
        test_port, robot_port, master_port = free_port(), free_port(), free_port()
        self.test_endpoint = f"tcp/127.0.0.1:{test_port}"
        cfg = BusConfig(robot=self.robot, listen=(f"tcp/127.0.0.1:{test_port}",), multicast=False)
        self.node = Node("nav_e2e_test", config=cfg, use_sim_time=False)
        base = {**os.environ, "ZENAV_ROBOT": self.robot, "ZENAV_MULTICAST": "0", "ZENAV_MODE": "peer",
                "PYTHONPATH": str(REPO)}
        base.pop("ZENAV_USE_SIM_TIME", None)
        self.bus_env = base  # this stack's bus, for tools run on it (node_stats)
        self.procs: list[NavProc] = []
        try:
            self.gt = self.node.subscribe("ground_truth", Odometry)
            self.collisions = NavTimeline(self.node, "collision", Collision)
            self.cmd = NavTimeline(self.node, "cmd_vel", Twist)
            self.status = NavTimeline(self.node, "move_base/status", MoveBaseStatus, keep=20000)
            self.cancel_pub = self.node.publisher("move_base/cancel", reliable=True)  # one-shot: never dropped
            env_r = {**base, "ZENAV_LISTEN": f"tcp/127.0.0.1:{robot_port}",
                     "ZENAV_CONNECT": f"tcp/127.0.0.1:{test_port}"}
            self.robot_proc = self._start("robot", [*zenav_command(), "robot", "--config", str(ROBOT_CONFIG),
                                                    "--world", world, "--speed", str(speed)], env_r, tmp)
            env_m = {**base, "ZENAV_LISTEN": f"tcp/127.0.0.1:{master_port}",
                     "ZENAV_CONNECT": f"tcp/127.0.0.1:{test_port},tcp/127.0.0.1:{robot_port}"}
            master_cfg = self.master_cfg = master_config_for(planner, world, tmp, move_base, navfn)
            self.master_proc = self._start("master", [*zenav_command(), "master", "--config", str(master_cfg)],
                                           env_m, tmp)
            wait_until(lambda: self.gt.latest() is not None and self.status.last() is not None
                     and self.status.last().reason == "no goal" and self._costmaps_up(), 180.0,
                     "the simulator's ground truth, move_base/status and both costmaps", alive=self.dead)
            publisher_ready(self.cancel_pub)
        except BaseException:
            self.close()
            raise

    def _start(self, name: str, argv: list[str], env: dict, tmp: Path) -> NavProc:
        p = NavProc(tmp / f"{name}.log", argv, env)
        self.procs.append(p)
        return p

    def _costmaps_up(self) -> bool:
        from common.messages import Costmap

        if not hasattr(self, "_cm"):
            self._cm = [self.node.subscribe(f"{n}/costmap", Costmap)
                        for n in ("global_costmap", "local_costmap")]
        return all(s.latest() is not None for s in self._cm)

    def dead(self) -> str:
        for p in self.procs:
            if not p.alive():
                return f"{p.log_path.name} exited ({p.proc.returncode}):\n{p.log()}"
        return ""

    def logs(self) -> str:
        return "\n".join(f"--- {p.log_path.name}\n{p.log(4000)}" for p in self.procs)

    def node_stats(self, snapshots: int = 2, every: float = 2.0) -> str:
        """`zenav nodes --stats` on this stack's bus, ``snapshots`` times ``every`` s apart: for a failure
        message, so a subscription that stopped receiving shows as a count that no longer grows."""
        env = {**self.bus_env, "ZENAV_CONNECT": self.test_endpoint}
        out = []
        for i in range(snapshots):
            if i:
                time.sleep(every)
            try:
                r = subprocess.run([*zenav_command(), "nodes", "--stats"], env=env, capture_output=True, text=True,
                                   timeout=60, cwd=REPO)
                out.append(r.stdout + r.stderr)
            except subprocess.TimeoutExpired:
                out.append("(zenav nodes --stats did not finish within 60 s)")
        return f"\n--- zenav nodes --stats, {every:.0f} s apart\n".join([""] + out)

    def processes(self) -> dict[int, tuple[str, str]]:
        """pid -> (side, name): the two agents ("robot agent", "master agent"), their fork servers
        (common.fork_server) and their nodes (each node's --name)."""
        out = {}
        for p in self.procs:
            side = p.log_path.stem
            out[p.proc.pid] = (side, f"{side} agent")
            for k in p.children():
                with contextlib.suppress(OSError, ValueError, IndexError):
                    argv = Path(f"/proc/{k}/cmdline").read_bytes().split(b"\0")
                    if b"common.fork_server" in argv:
                        out[k] = (side, f"{side} fork server")
                    else:
                        out[k] = (side, argv[argv.index(b"--name") + 1].decode())
        return out

    def links(self) -> str:
        """Each process's open links (psutil): an agent's nodes should hold one loopback link to their
        agent (children: agent); in a mesh (children: mesh), links to every peer."""
        lines = []
        for pid, (_, name) in sorted(self.processes().items(), key=lambda kv: kv[1][1]):
            try:
                proc = psutil.Process(pid)
                tcp = [c for c in proc.net_connections(kind="tcp") if c.status == psutil.CONN_ESTABLISHED]
            except psutil.Error as e:
                lines.append(f"{name}: {e}")
                continue
            lines.append(f"{name}: {len(tcp)} TCP links")
        return "\n".join(lines)

    # -- measurements ---------------------------------------------------------------------------------
    def truth(self):
        return self.gt.latest().pose2d

    def local_planner_params(self):
        """The local planner's parameters as move_base loads them from the master's YAML."""
        from master_side import agent as master_agent
        from master_side.move_base.config import load_move_base_config

        launch = master_agent.load(str(self.master_cfg))
        return load_move_base_config(*launch.node_params(launch.entry("move_base"))).local_params

    def collision_count(self) -> int:
        last = self.collisions.last()
        return 0 if last is None else last.count

    def goal(self, x: float, y: float, yaw: float, frame: str = "map", timeout: float = 150.0):
        """send_goal (zenav goal's function); returns (exit code, final status, wall t0, wall t1)."""
        from deploy.stack.goals import send_goal

        t0 = time.monotonic()
        code, st = send_goal(self.node, x, y, yaw, frame, timeout, echo=lambda *_: None)
        return code, st, t0, time.monotonic()

    def close(self) -> None:
        for p in reversed(self.procs):  # master first, then the robot
            p.stop()
        self.node.close()


def publisher_ready(pub, timeout: float = 60.0) -> None:
    wait_until(lambda: pub._pub.matching_status.matching, timeout, "a subscriber of the publisher")


def pose_error(truth, goal: tuple[float, float, float]) -> tuple[float, float]:
    """(xy error m, |yaw error| rad) of a Pose2D against (x, y, yaw)."""
    return (math.hypot(truth.x - goal[0], truth.y - goal[1]),
            abs(math.remainder(truth.theta - goal[2], 2 * math.pi)))
