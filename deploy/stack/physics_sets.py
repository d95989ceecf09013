"""What zenav's configurations change on the physics engine: their model of the robot they drive.

On MuJoCo the skid-steered P3-AT pivots 0.12 m behind base_link when it turns (MobileRobots' URDF puts its
centre of mass 0.1 m behind the axles, so the rear tyres carry most of the weight; measured with
``python bench/turning.py --engine mujoco``). zenav's configurations are told so:

- the robot's odometry (the simulated driver's ``odom_rotation_center_x``, as the p2os driver's): each
  increment taken as a turn about that point, so AMCL, gmapping and the local costmap see the robot move
  as it does;
- the robot-side collision monitor (``rotation_center_x``), whose approach polygon is moved along the
  commanded arc about that point;
- DWA (``p3at_zenav/dwa_planner_ros_mujoco.yaml``: ``rotation_center_x``; mapping with SLAM,
  ``dwa_planner_ros_slam_mujoco.yaml``), which predicts its trajectories so;
- AMCL, which then reads the odometry with ROS's ``omni`` model (``diff`` takes a sideways increment for a
  turn, a drive and a turn back, with both turns' noise).

The kinematic engine turns the robot about base_link: nothing changes there. The tutorial's own files
are left as ROS has them on either engine.
"""

from __future__ import annotations

from pathlib import Path

CONFIG = Path(__file__).resolve().parents[2] / "master_side" / "config"
PHYSICS_PIVOT_X = -0.12  # m, the P3-AT on MuJoCo (bench/turning.py: turn_center_x_m=-0.120)
PHYSICS_DWA = CONFIG / "p3at_zenav" / "dwa_planner_ros_mujoco.yaml"
PHYSICS_DWA_SLAM = CONFIG / "p3at_zenav" / "dwa_planner_ros_slam_mujoco.yaml"  # forward only, as while mapping

_ROBOT = {"mujoco": (f"sim.base.odom_rotation_center_x={PHYSICS_PIVOT_X}",
                    f"collision_monitor.rotation_center_x={PHYSICS_PIVOT_X}")}
_PLANNER = {"mujoco": (f"move_base.local_planner={PHYSICS_DWA}",)}
_PLANNER_SLAM = {"mujoco": (f"move_base.local_planner={PHYSICS_DWA_SLAM}",)}
_AMCL = {"mujoco": ("localization.odom_model_type=omni",)}


def robot_sets(engine: str | None) -> tuple[str, ...]:
    """``zenav robot --set`` values for the simulated P3-AT on ``engine``."""
    return _ROBOT.get(engine or "", ())


def master_sets(engine: str | None, amcl: bool) -> tuple[str, ...]:
    """``zenav master --set`` values for zenav's P3-AT configurations on ``engine`` (``amcl``: it localises
    with AMCL on a known map, p3at_zenav.yaml; else it maps with SLAM, p3at_slam_zenav.yaml: DWA drives
    forward only there, and gmapping's motion model takes a sideways increment as it is)."""
    if not amcl:
        return _PLANNER_SLAM.get(engine or "", ())
    return (*_PLANNER.get(engine or "", ()), *_AMCL.get(engine or "", ()))
