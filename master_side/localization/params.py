"""AMCL parameters, named and ranged as ROS amcl's (http://wiki.ros.org/amcl)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from common.config import load_params, param

# ROS amcl keys zenav accepts so a ROS amcl.yaml loads unchanged, but does not use (beam model,
# map service, pose saving).
UNUSED = ("laser_z_short", "laser_z_max", "laser_lambda_short", "use_map_topic",
          "first_map_only", "save_pose_rate", "gui_publish_rate", "tf_broadcast", "beam_skip_distance",
          "beam_skip_threshold", "beam_skip_error_threshold", "do_beamskip", "restore_defaults",
          "receive_map_topic", "selective_resampling")


@dataclass(frozen=True)
class AmclParams:
    # -- filter
    min_particles: int = param(100, lo=1, hi=1_000_000, doc="fewest particles (KLD lower bound)")
    max_particles: int = param(5000, lo=1, hi=1_000_000, doc="most particles (KLD upper bound)")
    kld_err: float = param(0.01, lo=1e-6, hi=1.0, doc="max error between true and estimated distribution")
    kld_z: float = param(0.99, lo=0.5, hi=0.999999, doc="upper standard normal quantile for (1 - p)")
    update_min_d: float = param(0.2, lo=0.0, hi=100.0, unit="m", doc="translation before a filter update")
    update_min_a: float = param(math.pi / 6, lo=0.0, hi=2 * math.pi, unit="rad",
                                doc="rotation before a filter update")
    resample_interval: int = param(2, lo=1, hi=1000, doc="filter updates between resamplings")
    transform_tolerance: float = param(0.1, lo=0.0, hi=10.0, unit="s",
                                       doc="map->odom is future-dated by this much")
    recovery_alpha_slow: float = param(0.0, lo=0.0, hi=1.0, doc="slow average weight filter (0 = off)")
    recovery_alpha_fast: float = param(0.0, lo=0.0, hi=1.0, doc="fast average weight filter (0 = off)")
    initial_pose_x: float = param(0.0, lo=-1e6, hi=1e6, unit="m", doc="initial pose mean x (map)")
    initial_pose_y: float = param(0.0, lo=-1e6, hi=1e6, unit="m", doc="initial pose mean y (map)")
    initial_pose_a: float = param(0.0, lo=-10.0, hi=10.0, unit="rad", doc="initial pose mean yaw (map)")
    initial_cov_xx: float = param(0.25, lo=0.0, hi=1e6, unit="m^2", doc="initial x variance")
    initial_cov_yy: float = param(0.25, lo=0.0, hi=1e6, unit="m^2", doc="initial y variance")
    initial_cov_aa: float = param((math.pi / 12) ** 2, lo=0.0, hi=100.0, unit="rad^2",
                                  doc="initial yaw variance")
    seed: int = param(0, lo=0, doc="random seed (zenav; 0 = from the OS)")
    # -- laser (likelihood field)
    laser_model_type: str = param("likelihood_field", choices=("likelihood_field", "likelihood_field_prob"),
                                  doc="sensor model: likelihood_field (1 + Σ pz³) or likelihood_field_prob (Π pz)")
    laser_min_range: float = param(-1.0, lo=-1.0, hi=1000.0, unit="m", doc="-1 = the scan's range_min")
    laser_max_range: float = param(-1.0, lo=-1.0, hi=1000.0, unit="m", doc="-1 = the scan's range_max")
    laser_max_beams: int = param(30, lo=2, hi=100_000, doc="evenly spaced beams used per scan")
    laser_z_hit: float = param(0.95, lo=0.0, hi=1.0, doc="weight of the hit (Gaussian) part")
    laser_z_rand: float = param(0.05, lo=0.0, hi=1.0, doc="weight of the random-measurement part")
    laser_sigma_hit: float = param(0.2, lo=1e-4, hi=10.0, unit="m", doc="std of the hit part")
    laser_likelihood_max_dist: float = param(2.0, lo=0.0, hi=100.0, unit="m",
                                             doc="distance map saturates here")
    laser_penalize_interior: bool = param(True, doc="zenav: beam end points inside an obstacle score by "
                                          "their depth (ROS: as on its surface)")
    refine_pose: bool = param(False, doc="zenav: at every scan, the pose is refined by a local search of the "
                              "scan's joint likelihood (refine.py); map→odom follows every scan, and at each "
                              "filter update the estimate's cluster is shifted by the correction; for a map made "
                              "by a laser SLAM (ROS: off)")
    refine_max_beams: int = param(180, lo=2, hi=100_000, doc="zenav: evenly spaced beams refine_pose scores")
    # -- odometry
    odom_model_type: str = param("diff", choices=("diff", "diff-corrected", "omni", "omni-corrected"),
                                 doc="'diff' / 'omni' keep ROS's original noise (variance used as std); omni: "
                                     "the alphas' roles differ (motion_model.OmniMotionModel)")
    odom_alpha1: float = param(0.2, lo=0.0, hi=100.0, doc="rotation noise from rotation (omni: translation and "
                                                         "strafe noise from rotation)")
    odom_alpha2: float = param(0.2, lo=0.0, hi=100.0, doc="rotation noise from translation")
    odom_alpha3: float = param(0.2, lo=0.0, hi=100.0, doc="translation noise from translation")
    odom_alpha4: float = param(0.2, lo=0.0, hi=100.0, doc="translation noise from rotation (omni: rotation "
                                                         "noise from rotation)")
    odom_alpha5: float = param(0.2, lo=0.0, hi=100.0, doc="omni only: strafe noise from translation")
    # -- frames
    odom_frame_id: str = param("odom", doc="odometry frame")
    base_frame_id: str = param("base_link", doc="robot frame")
    global_frame_id: str = param("map", doc="map frame")

    def validate(self) -> None:
        if self.min_particles > self.max_particles:
            raise ValueError(f"min_particles ({self.min_particles}) > max_particles ({self.max_particles})")
        if self.laser_z_hit + self.laser_z_rand <= 0.0:
            raise ValueError("laser_z_hit + laser_z_rand must be > 0")
        if 0 <= self.laser_max_range <= self.laser_min_range:
            raise ValueError("laser_max_range must exceed laser_min_range")


def load_amcl_params(cfg: dict | None, source: str = "<config>", section: str = "amcl",
                     ignore: tuple[str, ...] = ()) -> AmclParams:
    """AmclParams from a ROS amcl mapping; keys in UNUSED (and ``ignore``) are accepted and skipped."""
    return load_params(AmclParams, cfg, source=source, section=section, ignore=UNUSED + tuple(ignore))
