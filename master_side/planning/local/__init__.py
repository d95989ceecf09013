"""Local planners: sampled trajectories scored by pluggable cost functions (base_local_planner style)."""

from master_side.planning.local.base import Limits, LocalPlanner, LocalResult
from master_side.planning.local.dwa import DWAPlanner, DWAPlannerParams
from master_side.planning.local.scoring import ScoredSamplingPlanner
from master_side.planning.local.trajectory_planner import TrajectoryPlanner, TrajectoryPlannerParams

__all__ = [
    "DWAPlanner",
    "DWAPlannerParams",
    "Limits",
    "LocalPlanner",
    "LocalResult",
    "ScoredSamplingPlanner",
    "TrajectoryPlanner",
    "TrajectoryPlannerParams",
]
