"""One exploration run over the bus, as a user runs it, measured: ``zenav robot`` at a start in a world
(a zenav world such as ``room``, or an MRPB map), ``zenav master`` with SLAM while navigating (the
file given: bench/explore.py and ``zenav demo --explore`` give p3at_slam_zenav.yaml), then ``zenav
explore`` until it ends by itself (or a time limit: then it is interrupted as Ctrl-C would, and saves its
map). On a private loopback Zenoh network.

Measured from the bus while it runs: every map SLAM publishes is judged against the world
(deploy.stack.map_check.WorldTruth: the share of the reachable free area known as free) at the
simulator's time, so the time to a coverage is the robot's, not the machine's; the distance driven from
the simulator's ground truth; contacts from its ``collision`` topic, each with a snapshot of what the local
costmap held before it (``<run dir>/contacts/contact_<n>.npz``). At the end, the saved map's coverage
and agreement with the world (walls within two cells, free cells on free space). Each map is judged laid
on the world as well as it fits (``WorldTruth.fit``: SLAM's frame is the start only as well as the first
metres of odometry); the figures in the start's frame are kept beside them (``raw_*``)."""

from __future__ import annotations

import signal
import threading
import time
import uuid
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from common.bus import Node
from common.geometry import Pose2D
from common.messages import Empty, OccupancyGrid, Odometry
from common.ports import free_port
from deploy.mrpb.contacts import ContactWatch
from deploy.stack.map_check import FIT_HEADINGS_DEG, NO_OFFSET, WorldTruth
from deploy.stack.png import write_png
from deploy.stack.process_group import ProcessGroup, set_options
from deploy.stack.slam_counters import scan_counters
from master_side.mapping.map_io import load_map
from robot_side.sim.world import is_map_world

STARTUP_S = 120.0  # wall seconds for the agents to come up on a busy machine
REFIT_S = 20.0  # simulated seconds between fits of the map's frame while the run goes on


@dataclass
class ExploreRun:
    name: str
    end: str  # "done" (explore ended by itself), "time limit", "failed: ..."
    coverage: list[tuple[float, float]] = field(default_factory=list)  # (sim s from the start, share)
    final_share: float = 0.0
    walls_ok: float = 0.0  # agreement: occupied cells within two cells of a true wall
    free_ok: float = 0.0  # agreement: free cells on true free space
    offset: Pose2D = NO_OFFSET  # the saved map's frame, fitted, in the start's frame
    raw_share: float = 0.0  # final_share and walls_ok with the map's frame at the start, not fitted
    raw_walls_ok: float = 0.0
    free_m2: float = 0.0  # the reachable free area of the world
    path_m: float = 0.0
    collisions: int = 0
    contacts: list[tuple[float, float, float]] = field(default_factory=list)  # (sim s, x, y in the world)
    # per contact: how far from the touched point the nearest mark of the local costmap was just before it
    # (None: no costmap yet); a mark within a cell or two: the planner knew of the wall
    contact_marks: list[float | None] = field(default_factory=list)
    sim_s: float = 0.0
    wall_s: float = 0.0
    log_dir: str = ""
    slam: str = ""  # what the SLAM node said of its scans at the end (received, dropped by its queue, mapped)

    def time_to(self, share: float) -> float:
        """Simulated seconds until the coverage first reached ``share`` (inf: never)."""
        return next((t for t, s in self.coverage if s >= share), float("inf"))

    @property
    def agreement(self) -> float:
        return min(self.walls_ok, self.free_ok)


class _Watch:
    """Coverage of each map as it comes (judged in this thread, not in Zenoh's), distance, contacts."""

    def __init__(self, node: Node, truth: WorldTruth, contact_dir: Path | None = None):
        self.node, self.truth, self.lock = node, truth, threading.Lock()
        self.maps = node.subscribe("map", OccupancyGrid)
        self.t0: float | None = None
        self.path = 0.0
        self.last: tuple[float, float] | None = None
        self.coverage: list[tuple[float, float]] = []
        self._judged: OccupancyGrid | None = None
        self.offset, self._fitted_at = NO_OFFSET, -np.inf  # the map frame's fit, from the last one
        # contacts timed from the run's start, each with a snapshot in contact_dir (contact_<n>.npz); the
        # ground truth it follows gives the distance driven too. Made last: its subscriptions call _odom at once
        self.contacts = ContactWatch(node, contact_dir, when=lambda _m: self.now() - (self.t0 or 0.0),
                                     on_truth=self._odom)

    def _odom(self, m: Odometry) -> None:
        p = m.pose2d
        with self.lock:
            if self.last is not None:
                self.path += float(np.hypot(p.x - self.last[0], p.y - self.last[1]))
            self.last = (p.x, p.y)

    def now(self) -> float:
        """The simulator's time (the node is on use_sim_time="auto"), 0 before its first clock."""
        clock = self.node.clock
        return clock.now() if clock.simulated else 0.0

    def judge(self) -> None:
        m = self.maps.latest()
        if m is None or m is self._judged:
            return
        self._judged = m
        if self.t0 is None:
            self.t0 = self.now()
        if self.now() - self._fitted_at >= REFIT_S:
            self.offset, self._fitted_at = self.truth.fit(m, self.offset), self.now()
        self.coverage.append((self.now() - self.t0, self.truth.moved(self.offset).explored(m)))


INTERRUPTED = "interrupted"  # ExploreRun.end of a run stopped by Ctrl-C / SIGTERM (measured as far as it got)


def _slam_record(node: Node, work: Path) -> str:
    """The SLAM node's scan counters, and its trajectory (every scan it mapped, the best particle's pose)
    written to ``<run dir>/slam_trajectory.txt``: ``bench/slam_replay.py --live`` replays exactly those
    scans offline and judges the live trajectory beside its own (a live run can differ from a replay)."""
    from common.bus import ServiceError
    from master_side.slam.trajectory import from_message, write_trajectory

    try:
        got = scan_counters(node)
        stamps, poses = from_message(node.call("slam_gmapping/trajectory", Empty(), timeout=30.0))
    except ServiceError as e:  # a diagnosis: a run whose SLAM node is gone is still measured
        return f"SLAM node silent ({e})"
    write_trajectory(work / "slam_trajectory.txt", stamps, poses)
    return f"{got}, {len(stamps)} mapped"


def run_exploration(name: str, world: str, start: Pose2D, robot_config: Path, master_config: Path,
                    workdir: Path, speed: float = 2.0, time_limit_s: float = 1800.0, explore_args=(),
                    echo=print, monitor_args: tuple[str, ...] = (), robot: str = "",
                    endpoint: str = "", before_stop=None, master_set: tuple[str, ...] = (),
                    robot_args: tuple[str, ...] = (), record: tuple[str, ...] = ()) -> ExploreRun:
    """``world``: a zenav world name or a map YAML; ``start``: where the robot starts in it (SLAM's map
    frame); ``time_limit_s``: simulated seconds from the first map; ``monitor_args``: also run
    ``zenav monitor`` with these (e.g. ``--serve-web PORT``); ``robot`` / ``endpoint``: the private
    network's robot name and endpoint (default: new ones); ``before_stop(run)``: called with the measured
    run once the robot and master are stopped, before the monitor is (``zenav demo --serve-web`` keeps
    the page up there); ``master_set``: ``NODE.KEY=VALUE`` overrides for ``zenav master --set``;
    ``robot_args``: more ``zenav robot`` options (``--engine mujoco``); ``record``: topics ``zenav record``
    writes into ``<run dir>/run.mcap`` (``zenav slam run`` reads it again: SLAM offline on the same data).

    A map_server map's world ends at the map's edge (the simulator's ``edge_walls``, the judge's too): the
    building is what is to be explored, and MRPB's mall has openings in its outer wall with its map's edge
    beyond them, through which the robot could drive off the map and explore empty floor for ever."""
    wall0 = time.monotonic()
    work = Path(workdir) / name.replace("/", "_")
    work.mkdir(parents=True, exist_ok=True)
    robot = robot or f"explore{uuid.uuid4().hex[:6]}"
    endpoint = endpoint or f"tcp/127.0.0.1:{free_port()}"
    edge_walls = is_map_world(world)
    if edge_walls:
        robot_args = (*robot_args, *set_options(("sim.world_params.edge_walls=true",)))
    truth = WorldTruth.of(world, start, 0.05, edge_walls=edge_walls)
    group = ProcessGroup(robot, endpoint, work)
    # on the simulator's time: a wall-clock node refuses what is stamped 300 s ahead of it, and at --speed 2
    # the simulator is that far ahead after five minutes (the coverage froze at 43 % in office02)
    node = Node("explore_bench", config=group.hub_config(),
                use_sim_time="auto")
    watch = _Watch(node, truth, work / "contacts")
    out = ExploreRun(name, "failed", free_m2=truth.free_m2, log_dir=str(work))
    completed = False
    try:
        if record:  # first, so it has the robot's tf_static and the first scans
            group.spawn("record", ["record", str(work / "run.mcap"), "--topics", ",".join(record)])
        group.spawn("robot", ["robot", "--config", str(robot_config), "--world", str(world),
                              "--start", str(start.x), str(start.y), str(start.theta), "--speed", str(speed),
                              *robot_args])
        sets = set_options(master_set)
        group.spawn("master", ["master", "--config", str(master_config), *sets])
        if monitor_args:
            group.spawn("monitor", ["monitor", *monitor_args])
        explore = group.spawn("explore", ["explore", "--save", str(work / "explored"), "--wait",
                                          str(STARTUP_S), *explore_args])
        next_note = time.monotonic() + 30.0
        try:
            while explore.poll() is None:
                group.check_alive(ignore=("explore", "record"))
                watch.judge()
                if watch.t0 is not None and watch.now() - watch.t0 > time_limit_s:
                    out.end = "time limit"
                    break
                if time.monotonic() > next_note and watch.coverage and watch.t0 is not None:
                    t, s = watch.coverage[-1]
                    now = watch.now() - watch.t0  # SLAM sends no map while the robot stands (temporalUpdate -1)
                    age = f" (the last map {now - t:.0f} s ago)" if now - t > 30.0 else ""
                    echo(f"  {name}: {now:.0f} s simulated, {100 * s:.1f} % known{age}")
                    next_note = time.monotonic() + 30.0
                time.sleep(0.5)
            else:
                out.end = {0: "done", 3: "stuck"}.get(explore.returncode, f"failed: explore exit {explore.returncode}")
        except KeyboardInterrupt:  # Ctrl-C on the bench: this run is measured as far as it got
            out.end = INTERRUPTED
        if explore.poll() is None:
            explore.send_signal(signal.SIGINT)  # as Ctrl-C: cancels its goal, saves the map
            explore.wait(60)
        out.slam = _slam_record(node, work)
        saved = work / "explored.yaml"
        # explore saves the map as it ends; one that failed (e.g. move_base silent) saved none: the last map
        # SLAM published is judged instead (before, such a run read 0 % known)
        grid = load_map(saved) if saved.exists() else watch.maps.latest()
        if grid is not None:
            out.raw_share, (out.raw_walls_ok, _) = truth.explored(grid), truth.agreement(grid)
            out.offset = truth.fit(grid, watch.offset, headings_deg=FIT_HEADINGS_DEG)
            fitted = truth.moved(out.offset)
            out.final_share = fitted.explored(grid)
            out.walls_ok, out.free_ok = fitted.agreement(grid)
            write_png(work / "walls.png", fitted.picture(grid))  # where the map is wrong, to look at
        out.sim_s = watch.now() - (watch.t0 or 0.0)
        completed = out.end != INTERRUPTED  # Ctrl-C: no before_stop (the page is not kept up)
    except RuntimeError as e:  # an agent died or never came up
        out.end = f"failed: {e}"
        completed = True
    finally:
        with watch.lock:
            out.path_m = watch.path
        with watch.contacts.lock:
            c = watch.contacts
            out.collisions, out.contacts, out.contact_marks = c.count, list(c.contacts), list(c.marks)
        out.coverage = list(watch.coverage)
        out.wall_s = time.monotonic() - wall0
        try:
            if before_stop is not None and completed:  # not on Ctrl-C
                for proc in ("explore", "master", "robot"):
                    group.stop(proc)
                before_stop(out)
        finally:
            group.stop()
            node.close()
    return out
