"""Issue 15: navigation over a bad link. Master and robot in two network namespaces joined by a user-space
link (linkem.py: this kernel has no netem), real processes on both sides, default Zenoh config (peer,
multicast scouting). The tutorial's robot (simulated Pioneer 3-AT, Kinect scan) with its collision
monitor, and the tutorial's known-map DWA master. The robot is the tutorial's Pioneer LX with its
SICK S300 (robot_side/config/pioneer_lx_sim.yaml; a Kinect cannot see the last 0.45 m in front of it,
where (c) happens), plus a camera_link frame at the laser's mount because the tutorial's costmap file names
camera_link as the sensor frame. The tests share one stack and run in order.

(a) 100 ms delay each way + 5 % packet loss: the goal is still reached, no collision.
(b) a 3 s partition while driving: the robot stops within cmd_vel_timeout + braking of the last command;
    after the link heals the same goal completes, nothing restarted.
(c) a box appears 0.1 m in front of the bumper as the link is cut while driving at 0.35 m/s (cmd_vel from a
    teleop node on the master's side, ``probe.py teleop``):
    command expiry alone would carry the robot 0.25 s + braking, further than that; the robot's own
    collision monitor acts on its next scan and the robot stops short of the box.
(d) a goal sent (once, as `zenav goal` sends it) while the link is cut is acknowledged by move_base after
    the heal. Every goal here is sent once: move_base acknowledges it (common/delivery.py).
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import time
import uuid
from pathlib import Path

import pytest
import yaml

from testkit.line_proc import LineProc
from testkit.netns_link import bus_env, linked_namespaces
from tests.support import wait_until

pytestmark = [pytest.mark.netns]

REPO = Path(__file__).resolve().parents[2]
HERE = Path(__file__).parent
ROBOT = REPO / "robot_side/config/pioneer_lx_sim.yaml"
MASTER = REPO / "master_side/config/p3at_known_map.yaml"
TIMEOUT, DECEL = 0.25, 1.0  # the robot config's cmd_vel_timeout and braking (m/s^2)
DECEL_TH = 2.0  # its angular braking (rad/s^2): the simulated base's default acc_lim_th (no preset)
SUCCEEDED, ACTIVE = 3, 1
KINDS = {"GT", "CMD", "SAFE", "COLL", "MON", "ST", "SENDING", "SENT", "ACK", "NOACK", "READY"}  # probe.py's lines


@pytest.fixture(scope="module")
def stack(tmp_path_factory):
    if os.geteuid() != 0:
        pytest.skip("needs root for network namespaces")
    tmp = tmp_path_factory.mktemp("link_faults")
    robot = f"lf{uuid.uuid4().hex[:6]}"
    env = bus_env(robot)
    with linked_namespaces("lf", "10.78.0", env, tmp) as ns:
        zenav = [sys.executable, "-m", "deploy.cli"]
        cfg = yaml.safe_load(ROBOT.read_text())
        cfg["transforms"]["laser_as_camera_link"] = {"args": "0.1 0 0.35 0 0 0 base_link camera_link 100"}
        (tmp / "robot.yaml").write_text(yaml.safe_dump(cfg, sort_keys=False))
        robot_proc = ns.start(ns.robot, [*zenav, "robot", "--config", str(tmp / "robot.yaml"), "--robot", robot],
                              "robot.log")
        ns.start(ns.master, [*zenav, "master", "--config", str(MASTER)], "master.log")
        probe = ns.start(ns.robot, [sys.executable, str(HERE / "probe.py")])
        teleop = ns.start(ns.master, [sys.executable, str(HERE / "probe.py"), "teleop"])
        def ready():
            st = probe.events("ST")
            return st and probe.events("GT") and " ".join(st[-1][5:]).rstrip(";") == "no goal"
        try:
            wait_until(ready, 240, "move_base ready (status 'no goal') across the link")
        except AssertionError:
            st = probe.events("ST")
            raise AssertionError(f"not ready; last status: {' '.join(st[-1][2:]) if st else 'none'}") from None
        wait_until(lambda: teleop.lines, 120, "the teleop probe on the master's side")
        yield {"probe": probe, "teleop": teleop, "link": ns.link, "robot_proc": robot_proc, "tmp": tmp,
               "ns_m": ns.master, "robot": robot, "env": env}


def _link(stack, cmd: str) -> None:
    assert stack["link"].command(cmd, 10) is not None, f"no answer from the link to {cmd!r} within 10 s"


def _teleop(stack, cmd: str) -> None:
    assert stack["teleop"].command(cmd, 30) is not None, f"no answer from the teleop to {cmd!r} within 30 s"


def _goal(probe: LineProc, x: float, y: float, yaw: float) -> tuple[float, str]:
    """Send a goal once, as `zenav goal` does (acknowledged by move_base); returns (send time, goal id)
    once move_base has taken it in. The probe's own deadline (90 s) ends in NOACK: a failure here."""
    t0 = time.time()
    probe.send(f"goal {x} {y} {yaw}")
    ans = wait_until(lambda: probe.events("ACK", t0) or probe.events("NOACK", t0), 120, "move_base's answer")[0]
    assert ans[1] == "ACK" and int(ans[3]) == ACTIVE, f"goal ({x}, {y}) not taken in: {' '.join(ans[1:])}"
    return t0, ans[2]


def _master_stats(stack) -> str:
    """`zenav nodes --stats` from the master's side: which subscription stopped receiving (a route that
    did not re-form after the heal shows as a topic whose count no longer grows)."""
    try:
        out = subprocess.run(["ip", "netns", "exec", stack["ns_m"], sys.executable, "-m", "deploy.cli", "nodes",
                              "--stats", "--robot", stack["robot"]], env=stack["env"], capture_output=True,
                             text=True, timeout=60)
        return out.stdout + out.stderr
    except subprocess.TimeoutExpired:
        return "(zenav nodes --stats did not finish within 60 s)"


def _reached(probe: LineProc, goal: tuple[float, str], timeout: float = 300.0, what: str = "goal",
             stack=None) -> None:
    since, gid = goal

    def done():
        st = [w for w in probe.events("ST", since) if w[3] == gid]
        if st and int(st[-1][2]) not in (ACTIVE, SUCCEEDED, 0):
            raise AssertionError(f"{what} ended with status {st[-1][2]}: {' '.join(st[-1][3:])}")
        return [w for w in st if int(w[2]) == SUCCEEDED]
    try:
        wait_until(done, timeout, f"{what} reached")
    except AssertionError as e:  # say where move_base stood (state, reason: 'no progress' = no cmd_vel route?)
        st = [w for w in probe.events("ST", since) if w[3] == gid]
        stats = f"\nmaster side:\n{_master_stats(stack)}" if stack else ""
        raise AssertionError(f"{e}; last status of {gid}: {' '.join(st[-1][2:]) if st else 'none'}{stats}") from None


def _moving(gt: list[str]) -> bool:
    """A probe GT line of a robot driving or turning (linear or angular speed over 1 mm/s, 1 mrad/s)."""
    return abs(float(gt[5])) > 1e-3 or abs(float(gt[7])) > 1e-3


def _speed_at_least(probe: LineProc, v: float, since: float) -> None:
    wait_until(lambda: [w for w in probe.events("GT", since) if abs(float(w[5])) >= v], 120, f"speed {v} m/s")


def test_a_goal_is_reached_over_100ms_delay_and_5_percent_loss(stack):
    probe = stack["probe"]
    _link(stack, "delay 0.1")
    _link(stack, "loss 0.05")
    try:
        g = _goal(probe, 2.0, 1.4, 1.5708)
        _reached(probe, g, what="far corner over the lossy link", stack=stack)
    finally:
        _link(stack, "loss 0")
        _link(stack, "delay 0")
    assert not probe.events("COLL", g[0])
    _link(stack, "stats")
    print(stack["link"].lines[-1])


def test_b_a_partition_stops_the_robot_and_the_goal_completes_after_it(stack):
    probe = stack["probe"]
    g = _goal(probe, -2.2, 0.0, math.pi)
    t0 = g[0]
    _speed_at_least(probe, 0.25, t0)
    _link(stack, "partition")
    t_cut = time.time()
    try:
        wait_until(lambda: time.time() > t_cut + 3.0, 10, "3 s of partition")
    finally:
        _link(stack, "heal")
    cmds = [w for w in probe.events("CMD", t0) if float(w[0]) <= t_cut + 0.05]
    t_last, v_last, sim_last = float(cmds[-1][0]), abs(float(cmds[-1][2])), float(cmds[-1][4])
    # the speeds to brake from: the last command's or the base's own when it came, whichever is higher
    gt_then = [w for w in probe.events("GT") if float(w[0]) <= t_last][-1]
    v_brake = max(v_last, abs(float(gt_then[5])))
    w_brake = max(abs(float(cmds[-1][3])), abs(float(gt_then[7])))
    # still: neither driving nor turning (a turn in place has no linear speed but is not a stop)
    stopped = [w for w in probe.events("GT", t_last) if not _moving(w)]
    assert stopped, "the robot never stopped during the partition"
    # Measured on the robot's clock (simulated time: ground truth's stamp against the clock when the last
    # command came), the time the robot's motion takes. On a busy machine the simulator runs slower than
    # the wall clock, and the collision monitor's cmd_vel_timeout runs on that same clock.
    # The robot's time when the last command came: the probe's last clock message then, or the ground truth
    # stamped before it, whichever is later. Both are lower bounds (a message's delivery lags under load);
    # the probe's clock alone once lagged 0.1 s, read as a stop 0.88 s after a command it took 0.78 s of wall
    # clock to follow (ci177).
    sim_last = max(sim_last, float(gt_then[6]))
    took = float(stopped[0][6]) - sim_last
    # linear and angular speed brake at once, each at its own limit; + monitor tick, ground truth period,
    bound = TIMEOUT + max(v_brake / DECEL, w_brake / DECEL_TH) + 0.1  # scheduling
    print(f"stopped {took:.3f} s of robot time ({float(stopped[0][0]) - t_last:.3f} s wall) after the last "
          f"command (braking from {v_brake:.2f} m/s, {w_brake:.2f} rad/s); bound {bound:.3f} s")
    assert took <= bound
    # after the stop in the robot's time: samples arrive in bursts on a loaded machine, and the stop's own
    # burst holds the braking samples before it at the same arrival time
    moved = [w for w in probe.events("GT", t_last) if float(w[6]) > float(stopped[0][6])
             and float(w[0]) < t_cut + 2.9 and _moving(w)]
    if moved:  # who told the base to move: the commands, the monitor's output and state around it, from
        t_m = float(moved[0][0])  # the last command before the cut to the motion
        trace = _trace(probe, t_last - 0.1, t_m + 0.1, ("CMD", "SAFE", "MON", "GT"))
        raise AssertionError(f"moved again while partitioned ({t_m - t_cut:.2f} s after the cut; stopped "
                             f"{float(stopped[0][0]) - t_cut:.2f} s after it):\n" + "\n".join(trace[:120]))
    _reached(probe, g, what="the same goal after the link healed", stack=stack)
    assert not probe.events("COLL", t0)


def _trace(probe, since: float, until: float = math.inf, kinds: tuple[str, ...] = ()) -> list[str]:
    """The probe's lines stamped within [since, until] (of ``kinds``, if given), in order, with the unstamped
    lines among them (its log: a warning, a traceback), which say most when something went wrong."""
    out, inside = [], False
    for w in list(probe.lines):
        try:
            t = float(w[0])
        except (ValueError, IndexError):  # a log line of the probe's node ("[netem_probe] ...")
            if inside:
                out.append(" ".join(w))
            continue
        inside = since <= t <= until
        if inside and len(w) > 1 and (not kinds or w[1] in kinds):
            out.append(" ".join(w))
    return out


def test_c_a_box_in_front_as_the_link_is_cut_is_stopped_for_by_the_robot_alone(stack):
    probe = stack["probe"]
    # Face north at the start (move_base), then drive north at 0.35 m/s from a teleop node on the master's
    # side: the speed over the link is the test's input, not what a planner chose to do on a loaded machine.
    _reached(probe, _goal(probe, -2.2, -0.2, math.pi / 2), what="facing north at the start", stack=stack)
    t0 = time.time()
    _teleop(stack, "drive 0.35 0.0")
    try:
        wait_until(lambda: [w for w in probe.events("GT", t0) if float(w[5]) >= 0.34], 60, "driving at 0.35 m/s")
    except AssertionError:
        _teleop(stack, "stop")
        raise
    v = float(probe.events("GT", t0)[-1][5])  # ~0.35 m/s: command expiry alone then exceeds the gap
    # the box is placed inside what command expiry alone would cover (the last command for cmd_vel_timeout,
    # then braking) but beyond what braking after 0.2 s of reaction needs: only a robot-side reaction stops
    gap = max(0.10, v * 0.2 + v**2 / (2 * DECEL))
    expiry_only = v * TIMEOUT + v**2 / (2 * DECEL)
    _link(stack, "partition")
    t_cut = time.time()
    ahead = 0.3302 + gap + 0.1  # the box's centre from base_link: bumper 0.33 m ahead, near face at gap
    try:
        probe.send(f"box {ahead} 0.0 0.2 0.6")
        try:
            sent = wait_until(lambda: probe.events("SENT", t_cut), 30, "box spawned")  # a loaded machine
        except AssertionError:  # seen twice: say what the probe printed after the cut, for the next look
            after = _trace(probe, t_cut - 0.2)
            raise AssertionError(f"box never spawned; probe after the cut ({len(after)} lines):\n"
                                 + "\n".join(after[:20] + ["..."] + after[-20:])) from None
        t_box = float(sent[0][0])
        heading = float([w for w in probe.events("GT", t0) if float(w[0]) <= t_box][-1][4])
        spawned = wait_until(lambda: _box_spawned(stack["robot_proc"]), 30, "the simulator's box line")
        # where base_link was when the simulator placed the box (``ahead`` in front of it): the distance to
        # the stop is then the distance towards the box's near face (from the probe's last ground truth before
        # it sent the box, it also held the motion until the simulator received it: a loaded run saw 0.13127
        # against a gap of 0.13125)
        start = (spawned[0] - ahead * math.cos(heading), spawned[1] - ahead * math.sin(heading))
        try:
            wait_until(lambda: [w for w in probe.events("GT", t_box + 0.1) if abs(float(w[5])) < 1e-3], 10, "stop")
        except AssertionError:
            trace = _trace(probe, t_cut - 0.2)[:80]
            raise AssertionError("never stopped:\n" + "\n".join(trace)) from None
        stop = [w for w in probe.events("GT", t_box + 0.1) if abs(float(w[5])) < 1e-3][0]
        travelled = ((float(stop[2]) - start[0]) * math.cos(heading)
                     + (float(stop[3]) - start[1]) * math.sin(heading))
        acted = [w[2] for w in probe.events("MON", t_cut) if w[2] in ("stop", "slowdown", "approach", "limit")]
        print(f"at {v:.2f} m/s: box {gap:.3f} m ahead, travelled {travelled:.3f} m to the stop (command expiry "
              f"alone: {expiry_only:.3f} m); monitor: {acted[:4]}")
        assert expiry_only > gap
        assert acted, "the collision monitor never acted"
        assert travelled < gap
        coll = probe.events("COLL", t0)
        if coll:  # when (sim time) and where it touched, against the motion and the monitor around it
            t_c = float(coll[0][0])
            trace = _trace(probe, t_cut - 0.2, t_c + 0.3, ("GT", "SAFE", "MON", "COLL", "SENT"))
            raise AssertionError(f"collision {coll[0][1:]} (count, sim stamp, contact x y); box line {spawned}, "
                                 f"start {start}, stop {stop}:\n" + "\n".join(trace[:150]))
    finally:
        _teleop(stack, "stop")  # before the heal: the stream must not push the robot on into the box
        _link(stack, "heal")


def _box_spawned(robot: LineProc) -> tuple[float, float] | None:
    """The box's centre in the world from the simulator's log line (its agent's stdout)."""
    for w in list(robot.lines):
        if "spawned" in w and "(world)" in w:
            return float(w[-3].removeprefix("x=")), float(w[-2].removeprefix("y="))
    return None


def test_d_a_goal_sent_during_a_partition_is_taken_in_after_the_heal(stack):
    probe = stack["probe"]
    _link(stack, "partition")
    t_cut = time.time()
    try:
        probe.send("goal -1.0 0.0 0.0")
        wait_until(lambda: time.time() > t_cut + 3.0, 10, "3 s of partition")
        assert not probe.events("ACK", t_cut), "acknowledged across a cut link"
    finally:
        _link(stack, "heal")
    t_heal = time.time()
    ans = wait_until(lambda: probe.events("ACK", t_cut) or probe.events("NOACK", t_cut), 120, "the answer")[0]
    assert ans[1] == "ACK", " ".join(ans)
    print(f"goal sent {t_heal - t_cut:.1f} s before the heal, acknowledged {float(ans[0]) - t_heal:.2f} s after it")
    assert int(ans[3]) == ACTIVE, " ".join(ans)
    # move_base works on it: its status names the goal (reaching it is test (a)'s and (b)'s subject)
    try:
        wait_until(lambda: [w for w in probe.events("ST", float(ans[0])) if w[3] == ans[2] and int(w[2]) == ACTIVE],
                   30, "move_base's status of the goal")
    except AssertionError as e:  # what did come: other statuses? none at all (the stream's route)? the probe's log
        st = probe.events("ST", t_cut)
        seen = list(dict.fromkeys(f"{w[2]} {w[3]} {w[4]}" for w in st))
        other = [" ".join(w) for w in list(probe.lines) if len(w) < 2 or w[1] not in KINDS][-15:]
        raise AssertionError(f"{e}: {len(st)} statuses since the cut, the last at "
                             f"{float(st[-1][0]) - t_heal:+.2f} s from the heal; distinct: {seen[-6:]}; "
                             f"probe log: {other}\nmaster side:\n{_master_stats(stack)}") from None
