"""AMCL accuracy and cost with the simulated Kinect scan: the room route of tests/amcl/test_amcl_e2e.py, in
one process (simulator + depth→scan + Amcl, no bus), over several odometry-noise seeds.

Run: python bench/amcl.py [--seeds 8] [--config master_side/config/p3at_amcl.yaml] [--set key=value ...]
     [--engine mujoco]   (the skid-steered P3-AT on physics: its odometry error comes from wheel slip)
     [--odom-rotation-center-x M]   (the simulated driver's: its odometry turns the base about that point)

Each seed drives the same route (start → (-1, 0) → (-1, 1.3) → (1.5, 1.3) → (1.5, -1.2)) with its own
odometry error and camera noise; errors are map→base_link (AMCL correction ∘ odometry) against ground
truth at every depth frame after the first leg. ``--set`` overrides an amcl parameter (to compare tunings).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from common.geometry import Pose2D  # noqa: E402
from common.messages import Twist  # noqa: E402
from deploy.stack.world_maps import export_world_map  # noqa: E402
from master_side.localization.amcl import Amcl  # noqa: E402
from master_side.localization.params import load_amcl_params  # noqa: E402
from master_side.mapping.map_io import load_map  # noqa: E402
from robot_side.depth.depth_to_scan import DepthToScan, DepthToScanParams  # noqa: E402
from robot_side.sim.node import load as load_sim  # noqa: E402

WAYPOINTS = [(-1.0, 0.0), (-1.0, 1.3), (1.5, 1.3), (1.5, -1.2)]
ROBOT_CONFIG = ROOT / "robot_side" / "config" / "p3at_sim.yaml"


def command(truth: Pose2D, goal) -> tuple[float, float, bool]:
    """Turn-then-drive toward ``goal`` (the e2e test's driver): (v, w, reached)."""
    dx, dy = goal[0] - truth.x, goal[1] - truth.y
    dist = math.hypot(dx, dy)
    if dist < 0.08:
        return 0.0, 0.0, True
    err = math.remainder(math.atan2(dy, dx) - truth.theta, 2 * math.pi)
    return (0.0 if abs(err) > 0.15 else min(0.35, dist)), max(-0.8, min(0.8, 1.5 * err)), False


def run(seed: int, amcl_cfg: dict, grid, robot: dict, engine: str | None = None,
        odom_cx: float | None = None) -> dict:
    """One drive of the route with noise ``seed``; ``robot`` is the robot agent's YAML (sim + depth_to_scan)."""
    sim_cfg = dict(robot["platform"]["sim"]["params"])
    sim_cfg["sim"] = {**sim_cfg.get("sim", {}), "seed": seed}
    if odom_cx is not None:
        sim_cfg["base"] = {**sim_cfg.get("base", {}), "odom_rotation_center_x": odom_cx}
    if engine:
        sim_cfg["engine"] = engine
    _, sim, _ = load_sim(sim_cfg, str(ROBOT_CONFIG))
    d2s = DepthToScan(DepthToScanParams(**{k: v for k, v in robot["sensors"]["depth_to_scan"]["params"].items()
                                           if k in ("range_min", "range_max", "scan_height")}))
    cam = sim.camera.p
    laser = Pose2D(cam.x, cam.y, 0.0)
    amcl = Amcl(load_amcl_params({**amcl_cfg, "seed": seed + 1}, "bench"), grid, laser)  # 0 = OS entropy
    leg, errs, cost = 0, [], []
    t_cmd = 0.0
    while leg < len(WAYPOINTS) and sim.time < 600:
        if sim.time >= t_cmd:  # the test commands at ~10 Hz
            v, w, reached = command(sim.ground_truth, WAYPOINTS[leg])
            leg += reached
            sim.cmd_vel(Twist.planar(v, w))
            t_cmd = sim.time + 0.1
        if "depth_camera" not in sim.step():
            continue
        img, info = sim.depth_frame()
        scan = d2s.convert(img, info)
        odom = sim.base.odom
        t0 = time.perf_counter()
        if amcl.update(odom, scan, laser):
            cost.append(time.perf_counter() - t0)
        corr = amcl.map_to_odom()
        if corr is not None and leg >= 1:
            est, truth = corr.compose(odom), sim.ground_truth
            errs.append((math.hypot(est.x - truth.x, est.y - truth.y),
                         abs(math.remainder(est.theta - truth.theta, 2 * math.pi))))
    e = np.array(errs)
    return {"seed": seed, "n": len(e), "xy_mean": e[:, 0].mean(), "xy_p95": np.percentile(e[:, 0], 95),
            "xy_max": e[:, 0].max(), "yaw_max": e[:, 1].max(), "update_ms": 1e3 * float(np.median(cost))}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=8, help="number of noise seeds (default 8)")
    ap.add_argument("--config", default=str(ROOT / "master_side" / "config" / "p3at_amcl.yaml"),
                    help="master config whose nodes.localization.params are used (default p3at_amcl.yaml)")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="override an amcl param, e.g. --set laser_model_type=likelihood_field (repeatable)")
    ap.add_argument("--engine", choices=("kinematic", "mujoco"), help="simulator engine (default kinematic)")
    ap.add_argument("--odom-rotation-center-x", type=float, default=None, metavar="M",
                    help="the simulated driver's odom_rotation_center_x (-0.12 for the P3-AT on mujoco: "
                         "bench/turning.py); default the robot file's (none: odometry turning about base_link)")
    a = ap.parse_args(argv)
    from master_side import agent as master_agent

    launch = master_agent.load(a.config, sets=[f"localization.{kv}" for kv in a.set])  # as `zenav master` reads it
    amcl_cfg = dict(launch.node_params(launch.entry("localization"))[0])
    import tempfile
    with tempfile.TemporaryDirectory() as tmp:
        grid = load_map(export_world_map("room", tmp))
    print(f"{'seed':>4} {'frames':>6} {'xy mean m':>9} {'xy p95 m':>9} {'xy max m':>9} {'yaw max rad':>11} "
          f"{'update ms':>9}", flush=True)
    robot, rows = yaml.safe_load(ROBOT_CONFIG.read_text()), []
    for s in range(a.seeds):
        r = run(s, amcl_cfg, grid, robot, a.engine, a.odom_rotation_center_x)
        rows.append(r)
        print(f"{r['seed']:>4} {r['n']:>6} {r['xy_mean']:>9.3f} {r['xy_p95']:>9.3f} {r['xy_max']:>9.3f} "
              f"{r['yaw_max']:>11.4f} {r['update_ms']:>9.2f}", flush=True)
    xy_max = max(r["xy_max"] for r in rows)
    print(f"amcl_xy_mean_m={np.mean([r['xy_mean'] for r in rows]):.3f} amcl_xy_max_m={xy_max:.3f} "
          f"amcl_yaw_max_rad={max(r['yaw_max'] for r in rows):.4f} "
          f"amcl_update_ms={np.median([r['update_ms'] for r in rows]):.2f} seeds={len(rows)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
