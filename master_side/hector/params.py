"""hector_mapping's parameters (names as in the ROS node), plus zenav's few matcher extras."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from common.config import load_params_file, param


@dataclass(frozen=True)
class HectorParams:
    # frames and TF (the node's)
    base_frame: str = param("base_link")
    map_frame: str = param("map_link", doc="hector's default; the tutorial-style configs set map")
    odom_frame: str = param("odom", doc="'' or equal to base_frame: publish map->base_frame directly")
    pub_map_odom_transform: bool = param(True, doc="publish map->odom (else map->base_frame)")
    pub_map_scanmatch_transform: bool = param(True, doc="also publish map->tf_map_scanmatch_transform_frame_name")
    tf_map_scanmatch_transform_frame_name: str = param("scanmatcher_frame")
    use_tf_scan_transformation: bool = param(True, doc="laser pose in base_frame from TF (else identity)")
    use_tf_pose_start_estimate: bool = param(False, doc="start each match from the TF pose of base_frame "
                                             "(map->base via odom) instead of the last estimate")
    scan_subscriber_queue_size: int = param(5, lo=1, hi=10000, doc="scans waiting for the matcher")
    map_pub_period: float = param(2.0, lo=0.0, unit="s", doc="map publishing period (0: every update)")
    scan_topic: str = param("scan")
    # map
    map_resolution: float = param(0.025, lo=0.005, hi=1.0, unit="m", doc="finest level's cell size")
    map_size: int = param(1024, lo=16, hi=16384, unit="cells", doc="finest level's side")
    map_start_x: float = param(0.5, lo=0.0, hi=1.0, doc="start position as a fraction of the map's width")
    map_start_y: float = param(0.5, lo=0.0, hi=1.0, doc="start position as a fraction of the map's height")
    map_multi_res_levels: int = param(3, lo=1, hi=6, doc="levels, each half the previous resolution")
    map_update_distance_thresh: float = param(0.4, lo=0.0, unit="m", doc="update the map after this travel")
    map_update_angle_thresh: float = param(0.9, lo=0.0, unit="rad", doc="... or this rotation")
    update_factor_free: float = param(0.4, lo=0.0, hi=0.5, doc="probability a free observation asserts")
    update_factor_occupied: float = param(0.9, lo=0.5, hi=1.0, doc="probability a hit asserts")
    # laser
    laser_min_dist: float = param(0.4, lo=0.0, unit="m", doc="beams shorter than this are dropped")
    laser_max_dist: float = param(30.0, lo=0.01, unit="m", doc="beams longer than this are dropped")
    laser_z_min_value: float = param(-1.0, unit="m", doc="accepted; a planar scan has no height",
                                     no_effect=True)
    laser_z_max_value: float = param(1.0, unit="m", doc="accepted; a planar scan has no height",
                                     no_effect=True)
    # accepted for compatibility
    output_timing: bool = param(False, no_effect=True, doc="accepted; zenav counts in `zenav nodes --stats`")
    advertise_map_service: bool = param(True, no_effect=True, doc="accepted; the map is a latched topic")
    pub_odometry: bool = param(False, no_effect=True, doc="accepted; not implemented")
    map_with_known_poses: bool = param(False, no_effect=True, doc="accepted; not implemented")
    pub_drawings: bool = param(False, no_effect=True, doc="accepted; the monitor draws")
    pub_debug_output: bool = param(False, no_effect=True, doc="accepted; the monitor draws")
    sys_msg_topic: str = param("syscommand", no_effect=True, doc="accepted; no reset command")
    pose_update_topic: str = param("poseupdate", no_effect=True, doc="accepted; not published")
    # zenav extras (hector hard-codes these)
    coarse_iterations: int = param(3, lo=1, hi=50, doc="Gauss-Newton iterations on the coarser levels")
    fine_iterations: int = param(5, lo=1, hi=50, doc="Gauss-Newton iterations on the finest level")
    search_linear: float = param(0.0, lo=0.0, hi=2.0, unit="m", doc="before Gauss-Newton, search the "
                                 "coarsest level ±this around the guess (cell steps) for the best overlap "
                                 "(0: off, as hector)")
    search_angular: float = param(0.0, lo=0.0, hi=1.5, unit="rad", doc="... and ±this in angle (0: off)")
    search_angular_step: float = param(0.025, lo=0.001, hi=0.5, unit="rad", doc="angle step of that search")
    gap_time: float = param(0.0, lo=0.0, unit="s", doc="a scan this long after the previous one (a gap in "
                            "the scans, in which the robot may have turned far) is matched after the wider "
                            "gap_search_* search on the coarsest level (0: off, as hector)")
    gap_search_angular: float = param(3.14, lo=0.0, hi=3.15, unit="rad", doc="that search's angle half-width")
    gap_search_linear: float = param(0.0, lo=0.0, hi=2.0, unit="m", doc="... and translation half-width")
    prior_sigma_xy: float = param(0.0, lo=0.0, unit="m", doc="soft prior keeping the match near its "
                                  "start (the prediction) where the map leaves it free, e.g. along a corridor "
                                  "whose end is out of range: Δxy² / this² is added to the cost (0: off, as hector)")
    prior_sigma_theta: float = param(0.0, lo=0.0, unit="rad", doc="the same for the angle (0: off)")
    unknown_probability: float = param(0.5, lo=0.0, hi=1.0, doc="what the matcher reads in a never-"
                                       "observed cell (hector: 0.5, which rewards pushing scan points into "
                                       "unexplored space, e.g. past a corridor's visible end)")
    ignore_unknown: bool = param(False, doc="a scan point whose nearest cell was never observed carries no "
                                 "information (no residual, no gradient) instead of reading unknown_probability: "
                                 "points the robot sees for the first time do not pull the match back to the "
                                 "last map update's pose")
    max_scan_motion_xy: float = param(0.5, lo=0.0, unit="m", doc="a last step longer than this is not "
                                      "extrapolated (the prediction is then the last pose)")
    max_scan_motion_theta: float = param(0.5, lo=0.0, unit="rad", doc="... nor one turning more than this")
    velocity_window: int = param(1, lo=1, hi=50, doc="the prediction's velocity is the median of the last "
                                 "this many per-scan steps (1: the last step)")
    predict_velocity: bool = param(True, doc="start each match from a constant-velocity prediction "
                                   "(the last two poses; no odometry) instead of the last pose")


def load_hector(path: str | Path | None = None, section: str = "", notes: list | None = None,
                **overrides) -> HectorParams:
    """Load hector_mapping parameters from a YAML file (or defaults); ``overrides`` win."""
    return load_params_file(HectorParams, path, section, overrides, notes=notes)
