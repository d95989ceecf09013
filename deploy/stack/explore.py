"""Exploration over the bus (``zenav explore``): the frontiers of SLAM's map while it grows (the map itself,
as explore_lite with costmap_topic map: the tutorial's SLAM costmaps track no unknown space), a goal to
move_base for the chosen one, until none is left (master_side/exploration: the search and the choice,
pure). Goals avoid the cells move_base's global costmap forbids (``costmap_forbidden``), so navfn accepts
them. Progress lines through ``echo``; the end says why and how much is known.

Time (``progress_timeout``, TF's stamps and ages) is the robot's: the simulator's ``clock`` when it publishes
one (a simulator slowed by a busy machine must not make a frontier look stuck, and one at --speed 2 stamps
TF ahead of the wall clock), else wall time."""

from __future__ import annotations

import contextlib
import math
import threading
import time
import uuid
from dataclasses import dataclass

import numpy as np

from common.messages import OccupancyGrid
from master_side.exploration.explorer import ExploreParams, Explorer
from master_side.exploration.frontiers import Grid, costmap_forbidden, grid_from_map, nearest_lethal_m, search
from master_side.move_base.machine_types import NO_PLAN


@dataclass
class ExploreReport:
    code: int  # 0 done (nothing left), 1 stopped (Ctrl-C), 2 no map or no move_base, 3 stuck (the robot cannot move)
    why: str
    map: OccupancyGrid | None = None  # the last map the run saw
    goals: int = 0
    failed: int = 0
    known_free_m2: float = 0.0
    seconds: float = 0.0

    def summary(self) -> str:
        how = {0: "done", 3: "stuck"}.get(self.code, "stopped")
        return (f"exploration {how}: {self.why}; {self.goals} goals sent "
                f"({self.failed} failed), {self.known_free_m2:.1f} m² known free, {self.seconds:.0f} s")


def known_free_m2(grid: Grid) -> float:
    """Free and inscribed cells: the free area the map knows."""
    return float(np.count_nonzero(grid.data <= 253) * grid.resolution**2)


def explore(node, params: ExploreParams, echo=print, stop: threading.Event | None = None, wait: float = 30.0,
            base_frame: str = "base_link") -> ExploreReport:
    from common.delivery import DeliveryFailed, cancel_goal, last_seen, send_goal
    from common.geometry import Pose2D
    from common.messages import Costmap, GoalStatus, Header, MoveBaseGoal, MoveBaseStatus, PointCloud, PoseStamped
    from common.tf import TFListener
    from deploy.stack.goals import send_goal as send_and_wait

    stop = stop or threading.Event()
    t0 = time.monotonic()
    maps = node.subscribe("map", OccupancyGrid)
    status = node.subscribe("move_base/status", MoveBaseStatus)
    costmaps = node.subscribe("global_costmap/costmap", Costmap)  # what move_base plans on (costmap_forbidden)
    results = node.subscribe("move_base/result", MoveBaseStatus, mode="queue")
    if params.visualize:
        pub_frontiers, pub_target = node.publisher("explore/frontiers"), node.publisher("explore/target")
    seen = last_seen(status, "move_base's status")
    deadline = time.monotonic() + wait
    while maps.latest() is None or status.latest() is None:
        if stop.is_set():
            return ExploreReport(1, "stopped before the map came", seconds=time.monotonic() - t0)
        if time.monotonic() > deadline:
            what = "no map (is SLAM running? zenav master --config master_side/config/p3at_slam_zenav.yaml)" \
                if maps.latest() is None else "no move_base"
            return ExploreReport(2, f"{what} on robot '{node.robot}' within {wait:g} s", seconds=wait)
        time.sleep(0.1)
    tf = TFListener(node)  # after the map came: a node on use_sim_time="auto" is on the robot's clock by then

    ex, report = Explorer(params), ExploreReport(0, "")
    goal_id, target, waiting = "", None, False
    period = 1.0 / params.planner_frequency
    if params.look_around:
        _look_around(node, tf, maps, costmaps, params.circumscribed_radius, base_frame, send_and_wait, echo, stop)
    while not stop.is_set():
        m = report.map = maps.latest()
        frame = m.header.frame_id or "map"
        try:
            pose = tf.buffer.lookup_pose2d(frame, base_frame, 0.0, timeout=1.0)
        except Exception as e:  # no transform yet: SLAM publishes map -> odom after its first scan
            echo(f"  waiting for {frame} -> {base_frame}: {e}")
            stop.wait(period)
            continue
        grid = grid_from_map(m.data, m.resolution, (m.origin.x, m.origin.y), params.inscribed_radius,
                             keep=(pose.x, pose.y))
        report.known_free_m2 = known_free_m2(grid)
        cm, no_goal = costmaps.latest(), None
        if cm is not None and cm.header.frame_id.lstrip("/") == frame.lstrip("/"):
            no_goal = costmap_forbidden(grid, Grid(cm.data, cm.resolution, (cm.origin.x, cm.origin.y)))
        while True:  # move_base's results for our goal: a failure blacklists its target
            try:
                r = results.get(timeout=0.0)
            except TimeoutError:
                break
            if r.goal_id != goal_id or target is None:
                continue
            if r.status == GoalStatus.SUCCEEDED:
                ex.goal_reached()
            else:
                ex.goal_failed(target, (pose.x, pose.y), r.reason, no_plan=r.reason.startswith(f"aborted: {NO_PLAN}"))
                report.failed += 1
                echo(f"  target ({target[0]:.2f}, {target[1]:.2f}) failed: {r.reason}; blacklisted")
            goal_id, target = "", None
        if ex.stuck:
            report.code, report.why = 3, ex.stuck
            break
        try:
            frontiers = search(grid, (pose.x, pose.y), params.potential_scale, params.gain_scale,
                               params.min_frontier_size, params.inscribed_radius, params.circumscribed_radius,
                               no_goal=no_goal)
        except ValueError as e:
            echo(f"  {e}")
            stop.wait(period)
            continue
        d = ex.plan(frontiers, node.clock.now(), (pose.x, pose.y))
        for (bx, by), why in ex.take_blacklisted():
            echo(f"  frontier ({bx:.2f}, {by:.2f}) blacklisted: {why}")
        if params.visualize:
            cells = np.concatenate([f.cells for f in frontiers]) if frontiers else np.zeros((0, 2))
            pts = np.column_stack((cells, np.full(len(cells), 0.02))).astype(np.float32)
            pub_frontiers.publish(PointCloud(Header(node.clock.now(), frame), pts))
        if d.action == "done":
            report.why = d.why
            break
        if d.action == "wait":  # nothing to go to now: look around once, SLAM may see more
            if not waiting:
                echo(f"  {d.why}: looking around, done if nothing shows within {params.done_timeout:g} s")
                if goal_id:
                    with contextlib.suppress(DeliveryFailed):
                        cancel_goal(node, goal_id, 5.0, seen)
                    goal_id, target = "", None
                if params.look_around:
                    _look_around(node, tf, maps, costmaps, params.circumscribed_radius, base_frame, send_and_wait,
                                 echo, stop)
            waiting = True
            stop.wait(period)
            continue
        waiting = False
        if d.action == "send" and d.target is not None and d.frontier is not None:
            target, goal_id, (gx, gy) = d.target, f"explore-{uuid.uuid4().hex[:8]}", d.frontier.goal
            cx, cy = d.frontier.centroid  # arrive facing the frontier
            yaw = math.atan2(cy - gy, cx - gx) if math.hypot(cx - gx, cy - gy) > 0.05 else \
                math.atan2(gy - pose.y, gx - pose.x)
            target_pose = PoseStamped(Header(node.clock.now(), frame), Pose2D(gx, gy, yaw).to_transform())
            goal = MoveBaseGoal(goal_id, target_pose)
            if params.visualize:
                pub_target.publish(target_pose)
            try:
                # ``wait``: a move_base starved for a few seconds on a busy machine is not gone (10 s ended
                # an office02 run that the robot was still exploring)
                send_goal(node, goal, wait, seen, cancelled=stop.is_set)
            except DeliveryFailed as e:
                report.code, report.why = 2, str(e)
                break
            report.goals += 1
            f = d.frontier
            echo(f"target {report.goals}: ({gx:.2f}, {gy:.2f}), a frontier of {f.size_m:.1f} m "
                 f"{f.min_distance:.1f} m away; {len(frontiers)} frontiers, {report.known_free_m2:.0f} m² known free")
        stop.wait(period)
    if stop.is_set() and report.code == 0 and not report.why:
        report.code, report.why = 1, "stopped (Ctrl-C)"
    if goal_id:
        with contextlib.suppress(DeliveryFailed):  # the way out: a cancel that does not arrive is said by move_base
            cancel_goal(node, goal_id, 5.0, seen)
    report.seconds = time.monotonic() - t0
    return report


def _look_around(node, tf, maps, costmaps, circumscribed: float, base_frame: str, send_and_wait, echo,
                 stop: threading.Event) -> None:
    """A full turn in place, a quarter at a time, each a move_base goal at the robot's position (a goal
    move_base gives up on ends the turn early: the frontiers take over). None where an obstacle of SLAM's map
    or the global costmap lies within the ``circumscribed`` radius: the turn would sweep it. Asked there at the
    end of the room's exploration, the local planner found every rotation colliding, move_base ran its
    recoveries for 34 simulated seconds and refused the goal as "in an obstacle"."""
    m = maps.latest()
    frame = m.header.frame_id or "map"
    try:
        pose = tf.buffer.lookup_pose2d(frame, base_frame, 0.0, timeout=5.0)
    except Exception as e:  # noqa: BLE001 - no pose yet: the frontiers' loop waits for it
        echo(f"  no look around: {e}")
        return
    grids = [grid_from_map(m.data, m.resolution, (m.origin.x, m.origin.y), 0.0, keep=(pose.x, pose.y))]
    cm = costmaps.latest()
    if cm is not None and cm.header.frame_id.lstrip("/") == frame.lstrip("/"):
        grids.append(Grid(cm.data, cm.resolution, (cm.origin.x, cm.origin.y)))
    near = min(nearest_lethal_m(g, pose.x, pose.y, circumscribed) for g in grids)
    if near < circumscribed:
        echo(f"  no look around at ({pose.x:.2f}, {pose.y:.2f}): an obstacle {near:.2f} m from the robot's centre, "
             f"inside the circle a turn sweeps (circumscribed_radius {circumscribed:g} m)")
        return
    echo(f"looking around at ({pose.x:.2f}, {pose.y:.2f}): four quarter turns")
    for k in range(1, 5):
        if stop.is_set():
            return
        code, st = send_and_wait(node, pose.x, pose.y, pose.theta + k * math.pi / 2, frame, 60.0,
                                 echo=lambda _s: None, cancel=stop)
        if code != 0:
            echo(f"  look around: quarter turn {k} ended: {st.reason if st is not None else f'exit {code}'}")
            return
