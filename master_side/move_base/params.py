"""move_base parameters, named as in ROS move_base (the tutorial's and BARN's move_base files load unchanged).

move_base plans and controls in the frames of its costmaps, as ROS does: goals are converted to the
global costmap's ``global_frame`` (``map`` for a known map, ``odom`` for BARN's odometry-only setup),
the robot pose comes from its ``robot_base_frame``. Parameters of move_base that zenav does not
implement are accepted and listed at start as having no effect.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from common.config import param

GLOBAL_PLANNERS = ("navfn/NavfnROS", "global_planner/GlobalPlanner", "nav_core/BaseGlobalPlanner")
LOCAL_PLANNERS = ("dwa_local_planner/DWAPlannerROS", "base_local_planner/TrajectoryPlannerROS",
                  "zenav/RegulatedPurePursuit")


@dataclass(frozen=True)
class MoveBaseParams:
    base_global_planner: str = param("navfn/NavfnROS", choices=GLOBAL_PLANNERS,
                                     doc="global planner plugin (navfn is the one implemented)")
    base_local_planner: str = param("base_local_planner/TrajectoryPlannerROS", choices=LOCAL_PLANNERS,
                                    doc="local planner: DWA, trajectory rollout, or zenav's regulated pure pursuit")
    controller_frequency: float = param(20.0, lo=0.1, hi=100.0, unit="Hz", doc="control loop rate")
    control_on_costmap: bool = param(
        False, doc="zenav: run the control cycle as soon as a new local costmap arrives (at most "
                   "controller_frequency times a second; without one every max(2/controller_frequency, 0.5) s); "
                   "false = ROS's fixed-rate loop")
    planner_frequency: float = param(0.0, lo=0.0, hi=100.0, unit="Hz",
                                     doc="global replanning rate; 0 = plan only on a new goal or failure")
    controller_patience: float = param(15.0, lo=0.0, unit="s",
                                       doc="time without a valid command before recovery")
    planner_patience: float = param(5.0, lo=0.0, unit="s", doc="time without a plan before recovery")
    max_planning_retries: int = param(-1, lo=-1, doc="planning failures before recovery; -1 = only patience")
    conservative_reset_dist: float = param(3.0, lo=0.0, unit="m",
                                           doc="costmap reset keeps obstacles within this square")
    recovery_behavior_enabled: bool = param(True, doc="run recovery behaviours when stuck")
    clearing_rotation_allowed: bool = param(True, doc="allow in-place rotation recoveries")
    recovery_behaviors: Any = param(None, doc="[{name, type}, ...] (clear_costmap_recovery/ClearCostmapRecovery, "
                                              "rotate_recovery/RotateRecovery); default: ROS's four")
    oscillation_timeout: float = param(0.0, lo=0.0, unit="s",
                                       doc="time to move oscillation_distance before recovery; 0 = off")
    oscillation_distance: float = param(0.5, lo=0.0, unit="m")
    max_in_place_rotation: float = param(
        4 * math.pi, lo=0.0, unit="rad",
        doc="zenav: in-place turning without translating (valid commands) that counts as a failed "
            "controller; 0 = off (ROS has no such check)")
    stall_timeout: float = param(
        0.0, lo=0.0, unit="s",
        doc="zenav: valid commands worth at least 0.1 m or 0.4 rad of motion that got the robot less than 5 cm "
            "or 0.2 rad (or a mix) for this long start the recoveries: the base is pushing on something its "
            "sensors do not show (a Pioneer reports it as a wheel stall); an escape then moves against the "
            "stalled command; 0 = off (ROS has no such check)")
    stall_marks: bool = param(
        False, doc="zenav: at each stall, publish stall_pointcloud (base frame): points just beyond the flank "
                   "points the stalled command pushed outwards, for the local costmap to mark as a bumper press "
                   "(stall_marks.py); a second later an empty cloud, so the marks stay only until rays clear them")
    no_progress_report: float = param(
        5.0, lo=0.0, unit="s",
        doc="zenav: while controlling with valid commands, the status says 'no progress' once the robot has "
            "moved less than 5 cm or turned less than 0.2 rad (or a mix) for this long; 0 = off (reports only: "
            "oscillation_timeout decides about recoveries, as in ROS)")
