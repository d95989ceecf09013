"""Parameters of the MuJoCo engine (``engine: mujoco``): the physics step, the floor, the gyro.

The robots' bodies are ``robot_side.sim.robot_bodies``; what the drive does with cmd_vel is the base's
``BaseParams`` (velocity and acceleration limits, cmd_vel timeout) in both engines.
"""

from __future__ import annotations

from dataclasses import dataclass

from common.config import param

__all__ = ["PhysicsParams", "ENGINES", "MUJOCO_INSTALL"]

ENGINES = ("kinematic", "mujoco")
MUJOCO_INSTALL = "pip install 'mujoco>=3.2' (or: bash deploy/install.sh)"


@dataclass(frozen=True)
class PhysicsParams:
    timestep: float = param(0.002, lo=1e-4, hi=0.01, unit="s",
                            doc="MuJoCo step; sim.dt is split into steps of this length")
    # No source gives the friction of these robots' tyres on an indoor floor: 0.9 is a middle value for
    # rubber on a dry hard floor; `python bench/barn.py --friction 0.6 / 1.2` measures the sensitivity
    # (README, Physics).
    friction: float = param(0.9, lo=0.05, hi=3.0, doc="sliding friction coefficient of wheel on floor")
    obstacle_friction: float = param(0.5, lo=0.0, hi=3.0, doc="sliding friction of robot body on obstacles")
    settle_time: float = param(0.3, lo=0.0, hi=5.0, unit="s",
                               doc="physics run before t = 0 so the robot rests on its wheels")
    gyro_noise_density: float = param(0.0, lo=0.0, hi=1.0, unit="rad/s/sqrt(Hz)",
                                      doc="white noise of the simulated yaw-rate gyro (bodies that fuse one)")
    seed: int = param(0, lo=0, doc="gyro noise RNG seed")
