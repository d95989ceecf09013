"""Simulator sensor cost in the room world: laser scans (SICK S300, 720 beams) and depth frames; the BARN
Jackal's Hokuyo UST-10LX (720 beams, 50 Hz) in the barn_demo world (0.01 m cells, 252 cylinders).

Run: python bench/sim.py   (targets: scan < 1 ms, VGA depth < 5 ms)
     python bench/sim.py --engine mujoco   the MuJoCo engine: the Jackal driving circles in barn_demo with
                                           its 720-beam scan at 50 Hz, then the P3-AT's Kinect (QVGA) in
                                           the room; ends with mujoco_step_ms=... mujoco_realtime_x=...
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from common.geometry import Pose2D  # noqa: E402
from robot_side.sim.depth_camera import DepthCamera, DepthCameraParams  # noqa: E402
from robot_side.sim.laser import Laser, LaserParams  # noqa: E402
from robot_side.sim.simulator import WORLDS_DIR  # noqa: E402
from robot_side.sim.world import load_world  # noqa: E402


def _poses(world, n: int, seed: int = 0, region=None) -> list[Pose2D]:
    rng = np.random.default_rng(seed)
    x0, y0, x1, y1 = region or world.bounds
    out = []
    while len(out) < n:
        x, y = rng.uniform(x0 + 0.6, x1 - 0.6), rng.uniform(y0 + 0.6, y1 - 0.6)
        if world.height_at(np.array([x]), np.array([y]))[0] == 0:
            out.append(Pose2D(x, y, rng.uniform(-np.pi, np.pi)))
    return out


def _time(fn, poses, repeat: int) -> np.ndarray:
    fn(poses[0])
    ts = []
    for i in range(repeat):
        t = time.perf_counter()
        fn(poses[i % len(poses)])
        ts.append(time.perf_counter() - t)
    return np.array(ts) * 1e3


def mujoco(seconds: float = 20.0) -> None:
    from common.messages import Twist
    from robot_side.sim.simulator import Simulator

    cfg = {"world": "barn_demo", "engine": "mujoco", "base": {"model": "jackal"}, "depth_camera": None,
           "laser": {"model": "hokuyo_ust10lx", "x": 0.055, "z": 0.31}}
    sim = Simulator.from_config(cfg)
    steps_per_dt = round(sim.params.dt / sim.base.phys.timestep)
    step_ms, scan_ms = [], []
    t_all = time.perf_counter()
    while sim.time < seconds:  # circles of 1 m radius at 0.8 m/s in the start box
        sim.cmd_vel(Twist.planar(0.8, 0.8))
        t = time.perf_counter()
        due = sim.step()
        step_ms.append((time.perf_counter() - t) * 1e3 / steps_per_dt)
        if "laser" in due:
            t = time.perf_counter()
            sim.scan()
            scan_ms.append((time.perf_counter() - t) * 1e3)
    wall = time.perf_counter() - t_all
    room = Simulator.from_config({"world": "room", "engine": "mujoco", "depth_camera": {"depth_mode": 5}})
    depth_ms = []
    for _ in range(60):
        room.cmd_vel(Twist.planar(0.3, 0.5))
        room.step()
        t = time.perf_counter()
        room.depth_frame()
        depth_ms.append((time.perf_counter() - t) * 1e3)
    st, sc, dp = np.array(step_ms), np.array(scan_ms), np.array(depth_ms)
    print(f"MuJoCo: Jackal in barn_demo ({sim.base.scene.model.ngeom} geoms), {seconds:g} s simulated, physics step "
          f"{sim.base.phys.timestep * 1e3:g} ms, scan 720 beams at {sim.laser.p.rate:g} Hz; P3-AT Kinect QVGA in room")
    print(f"{'case':<22} {'p50 ms':>8} {'p90 ms':>8} {'max ms':>8}")
    for name, a in (("physics_step", st), ("scan_720", sc), ("depth_qvga", dp)):
        print(f"{name:<22} {np.median(a):8.3f} {np.percentile(a, 90):8.3f} {a.max():8.3f}")
    print(f"mujoco_step_ms={np.median(st):.3f} mujoco_realtime_x={seconds / wall:.1f} "
          f"mujoco_scan_ms={np.median(sc):.3f} mujoco_depth_qvga_ms={np.median(dp):.2f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--engine", choices=("kinematic", "mujoco"), default="kinematic",
                    help="kinematic: the sensors' cost in our own engine; mujoco: a physics step with sensors")
    if ap.parse_args().engine == "mujoco":
        mujoco()
        return
    world = load_world(WORLDS_DIR / "room.yaml")
    poses = _poses(world, 50)
    cases = {
        "laser_s300_541": (Laser(world, Laser.preset("sick_s300")).scan, 300),
        "laser_720": (Laser(world, LaserParams(samples=720)).scan, 300),
        "depth_qvga": (DepthCamera(world, DepthCameraParams(depth_mode=5)).frame, 100),
        "depth_vga": (DepthCamera(world, DepthCameraParams(depth_mode=2)).frame, 60),
    }
    barn = load_world(WORLDS_DIR / "barn_demo.yaml")
    barn_poses = _poses(barn, 50, region=(-4.5, 0.0, 0.0, 9.6))  # inside the box and the field
    barn_laser = Laser(barn, Laser.preset("hokuyo_ust10lx", x=0.055, z=0.31)).scan
    print(f"world room {world.shape[1]}x{world.shape[0]} cells @ {world.resolution} m, noise on")
    print(f"{'case':<16} {'p50 ms':>8} {'p90 ms':>8} {'max ms':>8}")
    med = {}
    for name, (fn, n) in cases.items():
        ts = _time(fn, poses, n)
        med[name] = float(np.median(ts))
        print(f"{name:<16} {med[name]:8.3f} {np.percentile(ts, 90):8.3f} {ts.max():8.3f}")
    ts = _time(barn_laser, barn_poses, 300)
    med["barn_ust10"] = float(np.median(ts))
    print(f"{'barn_ust10_720':<16} {med['barn_ust10']:8.3f} {np.percentile(ts, 90):8.3f} {ts.max():8.3f}"
          f"   (barn_demo {barn.shape[1]}x{barn.shape[0]} cells @ {barn.resolution} m)")
    print(f"laser_scan_ms={med['laser_s300_541']:.3f} laser_720_ms={med['laser_720']:.3f} "
          f"depth_qvga_ms={med['depth_qvga']:.3f} depth_vga_ms={med['depth_vga']:.3f} "
          f"barn_ust10_ms={med['barn_ust10']:.3f}")


if __name__ == "__main__":
    main()
