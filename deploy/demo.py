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
from common.zenoh_config import BusConfig
from deploy.map_check import map_accuracy
from deploy.process_group import ProcessGroup
from deploy.world_maps import export_world_map, world_path
from master_side.mapping.map_io import save_map
from robot_side.sim.world import parse_pose

ROOT = Path(__file__).resolve().parents[1]
ROBOT_CONFIG = ROOT / "robot_side" / "config" / "p3at_sim.yaml"
# hector_mapping matches the scan alone (no odometry): the P3-AT carries a planar laser for it, the
# Kinect's 57-degree scan leaves it lost along plain walls (see the file's header)
HECTOR_ROBOT_CONFIG = ROOT / "robot_side" / "config" / "p3at_sim_laser.yaml"
MASTER_DIR = ROOT / "master_side" / "config"
PLANNERS = {
    "dwa": (MASTER_DIR / "p3at" / "move_base.yaml", MASTER_DIR / "p3at" / "dwa_planner_ros.yaml"),
    "trajectory": (MASTER_DIR / "move_base_trajectory_rollout.yaml",
                   MASTER_DIR / "p3at" / "base_local_planner_params.yaml"),
}


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



def amcl_node(world: str) -> dict:
    """The amcl node of p3at_amcl.yaml with its initial pose at ``world``'s start."""
    node = yaml.safe_load((MASTER_DIR / "p3at_amcl.yaml").read_text())["nodes"]["localization"]
    start = parse_pose(yaml.safe_load(world_path(world).read_text()).get("start", [0.0, 0.0, 0.0]))
    node["params"].update(initial_pose_x=start.x, initial_pose_y=start.y, initial_pose_a=start.theta)
    return node


def slam_method(slam: bool | str) -> str:
    """``DemoOptions.slam`` as a method name: "" (no SLAM), "gmapping" (also True) or "hector"."""
    return "gmapping" if slam is True else (slam or "")


def robot_config(slam: bool | str = False) -> Path:
    """The simulated P3-AT's robot config: the tutorial's Kinect, or the planar laser for hector."""
    return HECTOR_ROBOT_CONFIG if slam_method(slam) == "hector" else ROBOT_CONFIG


def master_config(world: str, planner: str, out_dir: Path, slam: bool | str = False, amcl: bool = False) -> Path:
    """A master YAML for ``world``: on its known map (map server + fake localisation, or AMCL), or
    mapping it with SLAM (gmapping as in the tutorial's section 3.6, or hector_mapping);
    absolute paths into the package."""
    mb, lp = PLANNERS[planner]
    common = str(MASTER_DIR / "p3at" / "costmap_common_params.yaml")
    local = str(MASTER_DIR / "local_costmap_padded.yaml")
    if slam_method(slam) == "hector":
        first = {"hector_mapping": {"module": "master_side.hector.node", "respawn": True,
                                    "params": {"hector": str(MASTER_DIR / "hector_p3at.yaml")}}}
        global_specific = str(MASTER_DIR / "p3at" / "global_costmap_params.yaml")
    elif slam:
        first = {"slam_gmapping": {"module": "master_side.slam.node", "respawn": True,
                                   "params": {"gmapping": str(MASTER_DIR / "p3at" / "gmapping.yaml"),
                                              "particles": 30}}}
        global_specific = str(MASTER_DIR / "p3at" / "global_costmap_params.yaml")
    else:
        fake = {"module": "robot_side.sim.fake_localization", "respawn": True}
        first = {"localization": amcl_node(world) if amcl else fake,
                 "map_server": {"module": "master_side.mapping.map_server_node",
                                "params": {"map": str(export_world_map(world, out_dir))}}}
        global_specific = str(MASTER_DIR / "global_costmap_known_map.yaml")
    cfg = {
        "use_sim_time": True,
        "nodes": {
            **first,
            "global_costmap": {"module": "master_side.costmap.node", "respawn": True,
                               "params": {"name": "global_costmap", "common": common,
                                          "specific": global_specific}},
            "local_costmap": {"module": "master_side.costmap.node", "respawn": True,
                              "params": {"name": "local_costmap", "common": common, "specific": local}},
            "move_base": {"module": "master_side.move_base.node", "respawn": True,
                          "params": {"move_base": str(mb), "local_planner": str(lp),
                                     "costmap_common": common, "local_costmap": local,
                                     "global_costmap": global_specific}},
        },
    }
    path = out_dir / f"master_{world}.yaml"
    path.write_text(yaml.safe_dump(cfg, sort_keys=False))
    return path


class Demo:
    def __init__(self, opts: DemoOptions, echo=print) -> None:
        self.o, self.echo = opts, echo
        self.endpoint = f"tcp/127.0.0.1:{free_port()}"
        self.work = Path(opts.workdir or tempfile.mkdtemp(prefix="zenav-demo-"))
        self.work.mkdir(parents=True, exist_ok=True)
        self.group = ProcessGroup(opts.robot, self.endpoint, self.work)
        self.node = Node("demo", config=BusConfig(robot=opts.robot, multicast=False, listen=(self.endpoint,)))
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
        from deploy.cmd_goal import send_goal

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
            self.spawn(f"master_{world}", ["master", "--config", str(master_config(
                world, self.o.planner, self.work, self.o.slam, self.o.amcl))])
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
