"""How a simulated base turns: where it turns about, and how much of a commanded turn it makes.

A differential drive turns about base_link at the commanded rate, and ROS's local planners predict
exactly that. A skid-steered base does neither: its tyres scrub, so it turns slower than its wheel speeds
say, and it pivots toward the axle that carries more of its weight, so base_link moves sideways while it
turns (the ICR kinematics of skid steering: the instantaneous centre of rotation's longitudinal coordinate).
This bench drives the base from rest with a few (v, w) commands on the chosen engine and fits, from the
simulator's ground truth, the point on base_link's x axis it turns about (``rotation_center_x``: the
base's sideways velocity is ``-rotation_center_x * w``) and the ratio of its true to its commanded
rotation (and its odometry's). ``rotation_center_x`` is the value DWA's parameter of that name takes, and
the odometry's ``odom_rotation_center_x`` (the simulated driver's, as p2os's): with
``--odom-rotation-center-x`` the odometry is integrated about that point: its own fitted centre
(``turn_odom_center_x_m``, the parameter by construction) shows the setting was applied, and beside
``turn_center_x_m`` whether the odometry now moves as the base does.

  python bench/turning.py --engine mujoco                 # the P3-AT on physics
  python bench/turning.py --engine mujoco --robot jackal
  python bench/turning.py --engine mujoco --odom-rotation-center-x -0.12
  python bench/turning.py --engine mujoco --odom-rotation-center-x -0.12 --motions=-0.1,0.15,-0.1,-0.15,0.1,0.15

Ends with turn_center_x_m=… turn_ratio=… turn_odom_ratio=… turn_odom_center_x_m=… (over all motions, after
each one's first 0.5 s).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from common.messages import Twist  # noqa: E402
from robot_side.sim.simulator import Simulator  # noqa: E402

MOTIONS = ((0.0, 0.4), (0.0, 0.7), (0.0, 1.0), (0.0, -0.7), (0.2, 0.5), (0.3, -0.8))  # (v m/s, w rad/s)
SETTLE_S = 0.5  # the first part of each motion (acceleration) is left out of the fit


def drive(engine: str, robot: str, v: float, w: float, seconds: float, odom_cx: float = 0.0) -> np.ndarray:
    """Rows (t, x, y, theta unwrapped, odom theta unwrapped, odom x, odom y) while holding (v, w)."""
    sim = Simulator.from_config({"world": "room", "engine": engine,
                                 "base": {"model": robot, "odom_rotation_center_x": odom_cx}})
    base, t0, rows = sim.base, sim.time, []
    th, oth = base.pose.theta, base.odom.theta
    last, olast = th, oth
    while sim.time - t0 < seconds:
        sim.cmd_vel(Twist.planar(v, w))
        sim.step()
        th += math.remainder(base.pose.theta - last, 2 * math.pi)
        oth += math.remainder(base.odom.theta - olast, 2 * math.pi)
        last, olast = base.pose.theta, base.odom.theta
        rows.append((sim.time - t0, base.pose.x, base.pose.y, th, oth, base.odom.x, base.odom.y))
    return np.array(rows)


def body_rates(t: np.ndarray, x: np.ndarray, y: np.ndarray, th: np.ndarray) -> tuple[np.ndarray, ...]:
    """Per step: (forward, sideways) velocity in the base's own frame and the turn rate."""
    dt = np.diff(t)
    dx, dy = np.diff(x), np.diff(y)
    mid = 0.5 * (th[1:] + th[:-1])
    c, s = np.cos(mid), np.sin(mid)
    return (c * dx + s * dy) / dt, (-s * dx + c * dy) / dt, np.diff(th) / dt


def fit_center_x(vy: np.ndarray, w: np.ndarray) -> float:
    """Least squares for vy = -cx * w."""
    return float(-(vy @ w) / (w @ w))


def motions(text: str) -> tuple[tuple[float, float], ...]:
    """``--motions``' v,w pairs (MOTIONS when empty)."""
    if not text:
        return MOTIONS
    vals = [float(x) for x in text.split(",")]
    if len(vals) % 2:
        raise SystemExit(f"--motions: v,w pairs expected, got {len(vals)} numbers")
    return tuple(zip(vals[::2], vals[1::2]))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 epilog="\n\n".join(__doc__.split("\n\n")[1:]),
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--engine", choices=("kinematic", "mujoco"), default="mujoco")
    ap.add_argument("--robot", choices=("p3at", "jackal", "pioneer_lx"), default="p3at")
    ap.add_argument("--seconds", type=float, default=3.0, help="how long each command is held")
    ap.add_argument("--motions", default="", metavar="V,W,...",
                    help="the commands to hold, as v,w pairs in one comma-separated list (default: "
                         + ",".join(f"{v:g},{w:g}" for v, w in MOTIONS) + ")")
    ap.add_argument("--odom-rotation-center-x", type=float, default=0.0, metavar="M",
                    help="the simulated driver's odom_rotation_center_x (default 0: odometry turns about base_link)")
    a = ap.parse_args()
    print(f"# {a.robot} on the {a.engine} engine, each command held {a.seconds:g} s from rest, the odometry "
          f"turning about x = {a.odom_rotation_center_x:g} m")
    print("| v cmd (m/s) | w cmd (rad/s) | w true (rad/s) | true / cmd | odometry / cmd | center x (m) "
          "| odometry's center x (m) |")
    print("|---|---|---|---|---|---|---|")
    fits: dict[str, list[np.ndarray]] = {"vy": [], "w": [], "ovy": [], "ow": []}
    all_ratio, all_odom = [], []
    for v, w in motions(a.motions):
        rows = drive(a.engine, a.robot, v, w, a.seconds, a.odom_rotation_center_x)
        t = rows[:, 0]
        _, vy, wt = body_rates(t, rows[:, 1], rows[:, 2], rows[:, 3])
        _, ovy, wo = body_rates(t, rows[:, 5], rows[:, 6], rows[:, 4])
        keep = t[1:] > SETTLE_S
        vy, wt, ovy, wo = vy[keep], wt[keep], ovy[keep], wo[keep]
        ratio, odom = float(np.mean(wt) / w), float(np.mean(wo) / w)
        print(f"| {v:.2f} | {w:+.2f} | {np.mean(wt):+.3f} | {ratio:.3f} | {odom:.3f} | {fit_center_x(vy, wt):+.3f} "
              f"| {fit_center_x(ovy, wo):+.3f} |")
        for k, arr in zip(("vy", "w", "ovy", "ow"), (vy, wt, ovy, wo)):
            fits[k].append(arr)
        all_ratio.append(ratio), all_odom.append(odom)
    f = {k: np.concatenate(v) for k, v in fits.items()}
    print(f"turn_center_x_m={fit_center_x(f['vy'], f['w']):.3f} turn_ratio={np.mean(all_ratio):.3f} "
          f"turn_odom_ratio={np.mean(all_odom):.3f} turn_odom_center_x_m={fit_center_x(f['ovy'], f['ow']):.3f} "
          f"engine={a.engine} robot={a.robot}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
