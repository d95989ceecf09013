"""Pure simulation of a Pioneer 3-AT, a Pioneer LX or a Clearpath Jackal with a laser and a Kinect-like depth
camera (no bus here). Two engines behind one ``Simulator``: ``kinematic`` (exact arcs on the world's height
grid) and ``mujoco`` (rigid-body physics: ``mujoco_base``, ``mujoco_sensors``, ``robot_bodies``)."""

from robot_side.sim.base import BaseParams, DiffDriveBase
from robot_side.sim.depth_camera import DepthCamera, DepthCameraParams
from robot_side.sim.laser import Laser, LaserParams
from robot_side.sim.simulator import Pacer, Simulator, SimulatorParams
from robot_side.sim.world import World, WorldParams, load_world

__all__ = ["BaseParams", "DiffDriveBase", "DepthCamera", "DepthCameraParams", "Laser", "LaserParams", "Pacer",
           "Simulator", "SimulatorParams", "World", "WorldParams", "load_world"]
