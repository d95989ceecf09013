"""``zenav demo``: the whole system on this machine — simulated robot agent, master agent and
monitor as separate processes over Zenoh — driving the reference tutorial's scenario.

For each world (the room with one wooden obstacle, then the corridor of objects) it starts the
robot agent on that world and the master agent on the world's map, sends the world's goals one by
one, and checks each against the simulator's ground truth. Everything runs on a private loopback
Zenoh network (multicast off), so a demo never talks to robots on the LAN.
"""

from __future__ import annotations

import math
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from common.bus import Node
from common.geometry import Pose2D, normalize_angle
from common.messages import Collision, Costmap, MoveBaseStatus, OccupancyGrid, Odometry
from common.ports import free_port
from deploy.stack.map_check import map_accuracy
from deploy.stack.process_group import ProcessGroup, set_options
from deploy.stack.slam_counters import scan_counters
from deploy.stack.world_maps import export_world_map, world_path
from master_side.mapping.map_io import save_map
from robot_side.sim.world import parse_pose

ROOT = Path(__file__).resolve().parents[2]
ROBOT_CONFIG = ROOT / "robot_side" / "config" / "p3at_sim.yaml"
# hector_mapping matches the scan alone (no odometry): the P3-AT carries a planar laser for it, the
# Kinect's 57-degree scan leaves it lost along plain walls (see the file's header)
HECTOR_ROBOT_CONFIG = ROOT / "robot_side" / "config" / "p3at_sim_laser.yaml"
MASTER_DIR = ROOT / "master_side" / "config"
# the shipped master files, one per mode (the agents run them as a user would: `zenav master --config`)
KNOWN_MAP = {"dwa": MASTER_DIR / "p3at_known_map.yaml", "trajectory": MASTER_DIR / "p3at_known_map_trajectory.yaml"}
AMCL, GMAPPING, HECTOR = (MASTER_DIR / f for f in ("p3at_amcl.yaml", "p3at_slam.yaml", "p3at_hector.yaml"))
# trajectory rollout instead of the files' DWA (move_base's two files, as in p3at_known_map_trajectory.yaml)
TRAJECTORY = {"move_base": MASTER_DIR / "move_base_trajectory_rollout.yaml",
              "local_planner": MASTER_DIR / "p3at" / "base_local_planner_params.yaml"}


@dataclass
class GoalResult:
    world: str
    name: str
    ok: bool
    reason: str
    seconds: float
    xy_error: float = math.nan
    yaw_error: float = math.nan


@dataclass
class DemoOptions:
    worlds: tuple[str, ...] = ("room", "corridor")
    planner: str = "dwa"
    max_goals: int = 0  # 0 = all goals of each world
    speed: float = 1.0
    goal_timeout: float = 180.0
    monitor_args: tuple[str, ...] = ()  # e.g. ("--save", "demo.rrd"); () = no monitor
    robot: str = "demo"
    workdir: str = ""
    slam: bool | str = False  # map the world with SLAM while navigating: "gmapping" (or True), "hector"
    amcl: bool = False  # known map, localised with AMCL instead of the simulator's ground truth
    engine: str = "kinematic"  # the simulator's engine: kinematic or mujoco
    results: list[GoalResult] = field(default_factory=list)



def slam_method(slam: bool | str) -> str:
    """``DemoOptions.slam`` as a method name: "" (no SLAM), "gmapping" (also True) or "hector"."""
    return "gmapping" if slam is True else (slam or "")


def robot_config(slam: bool | str = False) -> Path:
    """The simulated P3-AT's robot config: the tutorial's Kinect, or the planar laser for hector."""
    return HECTOR_ROBOT_CONFIG if slam_method(slam) == "hector" else ROBOT_CONFIG


def master_args(world: str, planner: str, out_dir: Path, slam: bool | str = False, amcl: bool = False) -> list[str]:
    """``zenav master`` arguments for ``world``: the shipped file of the mode — on the world's known map
    (fake localisation, or AMCL started at the world's start pose), or mapping it with SLAM (gmapping as
    in the tutorial's section 3.6, or hector_mapping) — with ``--map`` / ``--set`` for what the world and
    the planner change."""
    method = slam_method(slam)
    sets: list[str] = []
    if method:
        config = HECTOR if method == "hector" else GMAPPING
    elif amcl:
        config = AMCL
        start = parse_pose(yaml.safe_load(world_path(world).read_text()).get("start", [0.0, 0.0, 0.0]))
        sets += [f"localization.initial_pose_{k}={v:.6f}" for k, v in (("x", start.x), ("y", start.y),
                                                                    ("a", start.theta))]
    else:
        config = KNOWN_MAP[planner]
    if planner == "trajectory" and config != KNOWN_MAP[planner]:
        sets += [f"move_base.{k}={v}" for k, v in TRAJECTORY.items()]
    args = ["--config", str(config)]
    if not method:
        args += ["--map", str(export_world_map(world, out_dir))]
    return args + set_options(sets)


class Demo:
    def __init__(self, opts: DemoOptions, echo=print) -> None:
        self.o, self.echo = opts, echo
        self.endpoint = f"tcp/127.0.0.1:{free_port()}"
        self.work = Path(opts.workdir or tempfile.mkdtemp(prefix="zenav-demo-"))
        self.work.mkdir(parents=True, exist_ok=True)
        self.group = ProcessGroup(opts.robot, self.endpoint, self.work)
        self.node = Node("demo", config=self.group.hub_config(),
                         use_sim_time="auto")  # the simulator's stamps run ahead of the wall at --speed 2
        self.truth = self.node.subscribe("ground_truth", Odometry)
        self.collisions = self.node.subscribe("collision", Collision)
        self.status = self.node.subscribe("move_base/status", MoveBaseStatus)
        self.map_accuracy: dict = {}
        self.costmaps = [self.node.subscribe(f"{n}/costmap", Costmap) for n in ("global_costmap", "local_costmap")]

    # -- processes ---------------------------------------------------------------------------------
    def spawn(self, name: str, args: list[str]):
        return self.group.spawn(name, args)

    def stop(self, name: str | None = None, grace: float = 10.0) -> None:
        self.group.stop(name, grace)

    def _wait(self, what: str, cond, timeout: float) -> None:
        self.group.wait(what, cond, timeout)

    # -- the scenario --------------------------------------------------------------------------------
    def run(self) -> bool:
        from deploy.stack.goals import send_goal

        if self.o.monitor_args:
            self.spawn("monitor", ["monitor", *self.o.monitor_args])
        for world in self.o.worlds:
            spec = yaml.safe_load(world_path(world).read_text())
            goals = list(spec.get("goals", {}).items())[: self.o.max_goals or None]
            mode = (f"SLAM ({slam_method(self.o.slam)}), unknown map" if self.o.slam
                    else "known map" + (", AMCL" if self.o.amcl else ""))
            self.echo(f"[demo] world '{world}': starting the robot agent (simulated P3-AT, "
                      f"{'MuJoCo physics' if self.o.engine == 'mujoco' else 'kinematic engine'}) and the master "
                      f"agent ({self.o.planner} local planner, {mode}) ...")
            start = parse_pose(spec.get("start", [0.0, 0.0, 0.0]))
            n_truth, n_status = self.truth.received, self.status.received
            n_maps = [c.received for c in self.costmaps]
            self.spawn(f"robot_{world}", ["robot", "--config", str(robot_config(self.o.slam)), "--world", world,
                                          "--speed", str(self.o.speed), "--engine", self.o.engine])
            self.spawn(f"master_{world}", ["master", *master_args(
                world, self.o.planner, self.work, self.o.slam, self.o.amcl)])
            self._wait("the simulator", lambda n=n_truth: self.truth.received > n, 60)
            self._wait("move_base", lambda n=n_status: self.status.received > n, 90)
            self._wait("the costmaps", lambda n=n_maps: all(c.received > k for c, k in zip(self.costmaps, n)), 60)
            for i, (name, (x, y, yaw)) in enumerate(goals, 1):
                self.echo(f"[demo] {world}: goal {i}/{len(goals)} '{name}' ({x:.2f}, {y:.2f}, {yaw:.2f})")
                res = self._goal(world, name, float(x), float(y), float(yaw), send_goal, start)
                self.o.results.append(res)
                verdict = "reached" if res.ok else "FAILED"
                self.echo(f"[demo] {world}: '{name}' {verdict} in {res.seconds:.1f} s; error "
                          f"{res.xy_error:.2f} m / {math.degrees(res.yaw_error):.1f} deg  {res.reason}")
                if not res.ok:
                    break
            if self.o.slam:
                self._check_map(world, start)
            self.stop(f"master_{world}")
            self.stop(f"robot_{world}")
        return all(r.ok for r in self.o.results) and bool(self.o.results)

    def _check_map(self, world: str, start: Pose2D) -> None:
        """Save the SLAM map and measure it against the world (the map frame starts at the start pose)."""
        sub = self.node.subscribe("map", OccupancyGrid)
        try:
            grid = sub.wait_first(30.0)
        except TimeoutError:
            self.echo(f"[demo] {world}: no SLAM map received")
            return
        finally:
            sub.close()
        save_map(grid, self.work / f"slam_{world}")
        self.map_accuracy[world] = acc = map_accuracy(grid, world, start)
        self.echo(f"[demo] {world}: SLAM map saved to {self.work / f'slam_{world}.pgm'}: {acc}")
        self.echo(f"[demo] {world}: {self._slam_scans()}")

    def _slam_scans(self) -> str:
        """The SLAM node's scan counters (deploy.stack.slam_counters)."""
        from common.bus import ServiceError

        name = "hector_mapping" if slam_method(self.o.slam) == "hector" else "slam_gmapping"
        try:
            return f"{name}: {scan_counters(self.node, name)}"
        except ServiceError as e:
            return f"{name} did not answer node_stats ({e})"

    def _goal(self, world: str, name: str, x: float, y: float, yaw: float, send_goal,
              start: Pose2D) -> GoalResult:
        gx, gy, gyaw = x, y, yaw
        if self.o.slam:  # SLAM's map frame is where the robot started
            g = start.inverse().compose(Pose2D(x, y, yaw))
            gx, gy, gyaw = g.x, g.y, g.theta
        c0 = self.collisions.latest()
        n0 = c0.count if c0 else 0
        t0 = time.monotonic()
        last = [""]

        def progress(line: str) -> None:
            if line.strip().startswith(("PLANNING", "CLEARING")) and line != last[0]:
                self.echo(f"[demo]   {line.strip()}")
            last[0] = line

        code, status = send_goal(self.node, gx, gy, gyaw, "map", self.o.goal_timeout, progress)
        dt = time.monotonic() - t0
        truth = self.truth.latest()
        xy_err = yaw_err = math.nan
        if truth is not None:
            p = truth.pose2d
            xy_err, yaw_err = math.hypot(p.x - x, p.y - y), abs(normalize_angle(p.theta - yaw))
        c1 = self.collisions.latest()
        collisions = (c1.count if c1 else 0) - n0
        reason = status.reason if status is not None else "no answer from move_base"
        ok = code == 0 and collisions == 0
        if collisions:
            reason = f"{collisions} collision(s); {reason}"
        return GoalResult(world, name, ok, reason, dt, xy_err, yaw_err)

    def close(self) -> None:
        self.stop()
        self.node.close()
