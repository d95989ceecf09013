"""move_base parameters, named as in ROS move_base (the tutorial's move_base.yaml loads unchanged)."""

from __future__ import annotations

from dataclasses import dataclass

from common.config import param

GLOBAL_PLANNERS = ("navfn/NavfnROS", "global_planner/GlobalPlanner", "nav_core/BaseGlobalPlanner")
LOCAL_PLANNERS = ("dwa_local_planner/DWAPlannerROS", "base_local_planner/TrajectoryPlannerROS")


@dataclass(frozen=True)
class MoveBaseParams:
    base_global_planner: str = param("navfn/NavfnROS", choices=GLOBAL_PLANNERS,
                                     doc="global planner plugin (navfn is the one implemented)")
    base_local_planner: str = param("base_local_planner/TrajectoryPlannerROS", choices=LOCAL_PLANNERS,
                                    doc="local planner plugin: DWA or trajectory rollout")
    controller_frequency: float = param(20.0, lo=0.1, hi=100.0, unit="Hz", doc="control loop rate")
    planner_frequency: float = param(0.0, lo=0.0, hi=50.0, unit="Hz",
                                     doc="global replanning rate; 0 = plan only on a new goal or failure")
    controller_patience: float = param(15.0, lo=0.0, unit="s",
                                       doc="time without a valid command before recovery")
    planner_patience: float = param(5.0, lo=0.0, unit="s", doc="time without a plan before recovery")
    max_planning_retries: int = param(-1, lo=-1, doc="planning failures before recovery; -1 = only patience")
    conservative_reset_dist: float = param(3.0, lo=0.0, unit="m",
                                           doc="costmap reset keeps obstacles within this square")
    recovery_behavior_enabled: bool = param(True, doc="run recovery behaviours when stuck")
    clearing_rotation_allowed: bool = param(True, doc="allow in-place rotation recoveries")
    shutdown_costmaps: bool = param(False, doc="(accepted for compatibility; costmaps keep running)")
    oscillation_timeout: float = param(0.0, lo=0.0, unit="s",
                                       doc="time to move oscillation_distance before recovery; 0 = off")
    oscillation_distance: float = param(0.5, lo=0.0, unit="m")
    rotate_recovery_vel: float = param(0.5, lo=0.05, hi=3.0, unit="rad/s",
                                       doc="in-place rotation speed of the rotate recovery")
    global_frame: str = param("map", doc="frame goals are converted to and plans are made in")
    robot_base_frame: str = param("base_link")
    transform_tolerance: float = param(0.5, lo=0.0, unit="s", doc="max age of the robot pose TF")
