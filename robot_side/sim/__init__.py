"""Pure simulation of a Pioneer 3-AT, a Pioneer LX or a Clearpath Jackal with a laser and a Kinect-like depth
camera (no bus here). Two engines behind one ``Simulator``: ``kinematic`` (exact arcs on the world's height
grid) and ``mujoco`` (rigid-body physics: ``mujoco_base``, ``mujoco_sensors``, ``robot_bodies``).

The names below load on first use, so that a light submodule (``physics_params``, read by ``zenav robot
--help``) does not import the simulator and numpy with it."""

from __future__ import annotations

import importlib

_HOME = {"BaseParams": "base", "DiffDriveBase": "base", "DepthCamera": "depth_camera",
         "DepthCameraParams": "depth_camera", "Laser": "laser", "LaserParams": "laser", "Pacer": "simulator",
         "Simulator": "simulator", "SimulatorParams": "simulator", "World": "world", "WorldParams": "world",
         "load_world": "world"}
__all__ = sorted(_HOME)


def __getattr__(name: str):
    if name not in _HOME:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{_HOME[name]}"), name)
