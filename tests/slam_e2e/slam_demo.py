"""The SLAM-while-navigating run shared by the gmapping and hector e2e tests: one world's loop through
the demo machinery (robot + master agents on a private loopback bus), and the true walls' length."""

from __future__ import annotations

import math
from pathlib import Path

import yaml

from deploy.stack.demo import Demo, DemoOptions
from deploy.stack.world_maps import world_path


def wall_length(world: str) -> float:
    """Total length of ``world``'s walls (m)."""
    spec = yaml.safe_load(world_path(world).read_text())
    return sum(math.dist(w["from"], w["to"]) for w in spec["walls"])


def run_slam_demo(world: str, slam: bool | str, robot: str, workdir: Path, speed: float):
    """Drive ``world``'s goals with ``slam`` mapping it, the simulator at ``speed`` times real time (the
    master follows the sim clock, use_sim_time).
    Returns (every goal reached, goal results, the map check of the latched SLAM map or None)."""
    demo = Demo(DemoOptions(worlds=(world,), slam=slam, monitor_args=(), robot=robot, workdir=str(workdir),
                            speed=speed), echo=print)
    try:
        ok = demo.run()
    finally:
        demo.close()
    return ok, demo.o.results, demo.map_accuracy.get(world)
