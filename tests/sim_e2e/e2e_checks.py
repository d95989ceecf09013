"""The acceptance scenarios of issue 3, run against a simulator reachable on the test's bus (started
directly as ``robot_side.sim.node`` or through ``zenav robot``)."""

from __future__ import annotations

import math
import time

from common.geometry import Pose2D
from common.messages import Clock, Collision, Odometry, Twist
from robot_side.sim.base import BaseParams
from tests.sim_e2e.conftest import Recorder, publisher_matched, wait_until

START = Pose2D(0.0, 0.0, 0.0)
FRONT = max(x for x, _ in BaseParams().footprint)  # P3-AT bumper, m ahead of base_link


class Rig:
    """Recorders on the simulator's outputs and a cmd_vel publisher, once the simulator runs."""

    def __init__(self, node, proc, timeout: float = 90.0, cmd_topic: str = "cmd_vel") -> None:
        self.node, self.proc = node, proc
        self.clock = Recorder(node, "clock", Clock)
        self.odom = Recorder(node, "odom", Odometry)
        self.gt = Recorder(node, "ground_truth", Odometry)
        self.collision = Recorder(node, "collision", Collision)
        self.cmd = node.publisher(cmd_topic, reliable=True)  # a test command must not be dropped under load
        wait_until(lambda: len(self.odom) and len(self.gt) or not proc.alive(), timeout,
                   "odom + ground_truth")
        assert proc.alive(), proc.log()
        publisher_matched(self.cmd)

    def now(self) -> float:
        """Latest sim time received."""
        return self.clock.last().clock

    def wait_sim(self, seconds: float, timeout: float = 60.0) -> float:
        t_end = self.now() + seconds
        wait_until(lambda: self.now() >= t_end, timeout, f"{seconds} s of sim time")
        return t_end

    def drive(self, plan: list[tuple[float, float, float]], rate_hz: float = 20.0,
              until=None, timeout: float = 120.0) -> None:
        """Publish cmd_vel (v, w) for each (sim seconds, v, w) of ``plan`` at ``rate_hz`` wall; ``until()``
        true ends the plan early. Ends with a zero command."""
        deadline = time.monotonic() + timeout
        for duration, v, w in plan:
            t_end = self.now() + duration
            while self.now() < t_end and not (until and until()):
                assert time.monotonic() < deadline, "drive plan timed out"
                assert self.proc.alive(), self.proc.log()
                self.cmd.publish(Twist.planar(v, w))
                time.sleep(1.0 / rate_hz)
        self.cmd.publish(Twist.planar(0.0, 0.0))

    def wait_stopped(self, timeout: float = 60.0) -> Odometry:
        """Wait for odom twist zero for 0.3 s of sim time; returns the last odom."""
        def still():
            msgs = self.odom.msgs()
            if not msgs:
                return None
            t = msgs[-1].header.stamp
            recent = [m for m in msgs if m.header.stamp >= t - 0.3]
            ok = recent[0].header.stamp <= t - 0.29 and all(_speed(m) == 0.0 for m in recent)
            return msgs[-1] if ok else None
        return wait_until(still, timeout, "the robot to stop")


def _speed(m: Odometry) -> float:
    return abs(m.twist.linear.x) + abs(m.twist.angular.z)


def path_length(gt: list[Odometry]) -> tuple[float, float]:
    """Distance travelled and total absolute rotation along ground truth messages."""
    dist = turn = 0.0
    for a, b in zip(gt, gt[1:]):
        pa, pb = a.pose2d, b.pose2d
        dist += math.hypot(pb.x - pa.x, pb.y - pa.y)
        turn += abs(math.remainder(pb.theta - pa.theta, 2 * math.pi))
    return dist, turn


def check_odom_tf_ground_truth_agree(rig: Rig, tf, base: BaseParams, start: Pose2D = START) -> dict:
    """Drive straight then along an arc; odom, TF odom->base_link and ground truth agree within 4 sigma of
    the gmapping error model (srr, srt, str, stt) for the distance and rotation travelled."""
    # each leg ends on what ground truth shows, not on a duration: a safety stop (the collision monitor
    # holding a command while the depth scan is late on a loaded machine) makes a leg longer, not shorter
    t0 = rig.now()

    def moved() -> tuple[float, float]:
        return path_length([m for m in rig.gt.msgs() if m.header.stamp >= t0])
    rig.drive([(30.0, 0.5, 0.0)], until=lambda: moved()[0] >= 1.5)
    rig.drive([(30.0, 0.3, 0.5)], until=lambda: moved()[1] >= 1.5)
    rig.wait_stopped()
    odom = {round(m.header.stamp, 6): m for m in rig.odom.msgs()}
    gt_msgs = rig.gt.msgs()
    gt = {round(m.header.stamp, 6): m for m in gt_msgs}
    stamp = max(set(odom) & set(gt))
    o, g = odom[stamp], gt[stamp]
    assert (o.header.frame_id, o.child_frame_id) == (base.odom_frame_id, base.base_frame_id)
    assert g.header.frame_id == "map"
    assert g.child_frame_id == base.base_frame_id

    dist, turn = path_length([m for m in gt_msgs if m.header.stamp <= o.header.stamp])
    assert dist > 2.0, f"the robot did not drive the plan: {dist:.2f} m"
    assert turn > 1.0, f"the robot did not turn: {turn:.2f} rad"
    truth = start.inverse().compose(g.pose2d)  # odom starts at the start pose
    est = o.pose2d
    sig_rho = math.sqrt(base.srr ** 2 * dist + base.srt ** 2 * turn)
    sig_th = math.sqrt(base.str ** 2 * dist + base.stt ** 2 * turn)
    pos_err = math.hypot(est.x - truth.x, est.y - truth.y)
    th_err = abs(math.remainder(est.theta - truth.theta, 2 * math.pi))
    # heading error also displaces the position laterally: at most dist * heading error
    assert pos_err <= 4 * (sig_rho + dist * sig_th), (pos_err, sig_rho, sig_th, dist)
    assert th_err <= 4 * sig_th, (th_err, sig_th)
    if base.srr > 0 and base.stt > 0:
        assert pos_err + th_err > 1e-6, "odometry is exactly ground truth: no error model applied"

    ts = tf.buffer.lookup(base.odom_frame_id, base.base_frame_id, o.header.stamp, timeout=10.0)
    p = ts.transform.to_pose2d()
    assert math.hypot(p.x - est.x, p.y - est.y) < 1e-6
    assert abs(p.theta - est.theta) < 1e-6
    return {"dist": dist, "turn": turn, "pos_err": pos_err, "th_err": th_err}


def check_stale_cmd_vel_stops(rig: Rig, base: BaseParams, v: float = 0.4) -> None:
    """One cmd_vel, then silence: the robot moves for the timeout, then stops (sim time), and stays."""
    rig.cmd.publish(Twist.planar(v, 0.0))  # once, on a reliable publisher matched to the base
    t0 = rig.now()
    moving = wait_until(lambda: [m for m in rig.odom.msgs() if m.header.stamp > t0 - 0.5 and _speed(m) > 0],
                        20, "motion after a single cmd_vel")
    t1 = moving[0].header.stamp
    last = rig.wait_stopped()
    rig.wait_sim(1.0)
    msgs = [m for m in rig.odom.msgs() if m.header.stamp >= t1]
    t2 = max(m.header.stamp for m in msgs if _speed(m) > 0)  # last moving
    t3 = min(m.header.stamp for m in msgs if m.header.stamp > t2)  # first stopped
    dt = 0.01
    period = min(0.02, max(b.header.stamp - a.header.stamp for a, b in zip(msgs, msgs[1:])))
    reached = min(v, base.max_vel_x)
    decel = reached / base.acc_lim_x
    # the command arrived after the odom sample before t1: t_cmd >= t1 - period - dt
    assert t3 - t1 <= base.cmd_vel_timeout + decel + 2 * period + 2 * dt, (t1, t2, t3)
    assert t2 - t1 >= base.cmd_vel_timeout - period - dt, f"stopped early: moved {t2 - t1:.3f} s"
    after = [m for m in rig.odom.msgs() if m.header.stamp >= t3]
    assert all(_speed(m) == 0.0 for m in after), "moved again without a command"
    assert last.header.stamp >= t3


def check_wall_collision(rig: Rig, wall_x: float, resolution: float, start: Pose2D = START) -> None:
    """Drive at a wall whose face is at x = wall_x: a collision is reported, the robot stops there and its
    ground truth never goes through the wall."""
    rig.drive([(60.0, 0.5, 0.0)], until=lambda: len(rig.collision) > 0)
    hit = rig.collision.last()
    assert hit is not None
    assert hit.count >= 1
    rig.drive([(1.0, 0.5, 0.0)])  # keep pushing: nothing moves
    rig.wait_stopped()
    gt = rig.gt.msgs()
    front = [m.pose2d.x + FRONT for m in gt]
    assert max(front) <= wall_x + resolution, f"bumper at {max(front):.3f} m, wall face at {wall_x} m"
    assert max(front) >= wall_x - 0.1 - resolution, f"stopped {wall_x - max(front):.3f} m before the wall"
    # from the first ground truth at or after the collision on, nothing moves (not the last one before it:
    # a loaded machine can drop the samples just before the hit, and that one is then centimetres back)
    after = [m.pose2d.x for m in gt if m.header.stamp >= hit.header.stamp]
    assert after, "no ground truth after the collision"
    assert max(after) - after[0] < 0.01, f"pushed {max(after) - after[0]:.3f} m into the wall after the collision"
    assert abs(hit.x - wall_x) <= 0.1 + resolution
    assert hit.header.frame_id == "map"
    assert abs(gt[-1].pose2d.y - start.y) < 0.05
