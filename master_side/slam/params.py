"""gmapping parameters (names as in the slam_gmapping ROS node) plus this matcher's search window."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from common.config import load_params_file, param

# ROS-side keys of slam_gmapping that the pure filter does not use (frames, timing of the node)
NODE_ONLY = ("base_frame", "odom_frame", "map_frame", "throttle_scans", "transform_publish_period",
             "occ_thresh", "inverted_laser", "tf_delay")


@dataclass(frozen=True)
class GMappingParams:
    # sensor
    maxUrange: float = param(80.0, lo=0.1, unit="m", doc="usable range: beams are cut to this")
    maxRange: float = param(81.0, lo=0.1, unit="m", doc="ranges at or beyond this are 'no return'")
    # scan matcher
    sigma: float = param(0.05, lo=1e-4, unit="m^2", doc="gmapping's score kernel (accepted; the "
                         "correlative matcher scores with match_sigma)")
    kernelSize: int = param(1, lo=0, hi=10, unit="cells", doc="search radius (cells) around each endpoint")
    lstep: float = param(0.05, lo=1e-4, unit="m", doc="initial hill-climb translation step")
    astep: float = param(0.05, lo=1e-5, unit="rad", doc="initial hill-climb rotation step")
    iterations: int = param(5, lo=0, hi=100, doc="hill-climb step refinements")
    lsigma: float = param(0.075, lo=1e-4, unit="m^2", doc="likelihood kernel of one beam")
    ogain: float = param(3.0, lo=1e-3, doc="likelihood smoothing gain for the weights")
    lskip: int = param(0, lo=0, hi=100, doc="use every (lskip+1)-th beam")
    minimumScore: float = param(0.0, lo=0.0, doc="accept the scan-match only above this score")
    # motion model
    srr: float = param(0.1, lo=0.0, doc="translation error from translation")
    srt: float = param(0.2, lo=0.0, doc="rotation error from translation")
    str_: float = param(0.1, lo=0.0, aliases=("str",), doc="translation error from rotation")
    stt: float = param(0.2, lo=0.0, doc="rotation error from rotation")
    # update triggers
    linearUpdate: float = param(1.0, lo=0.0, unit="m", doc="process a scan after this much travel")
    angularUpdate: float = param(0.5, lo=0.0, unit="rad", doc="process a scan after this much rotation")
    temporalUpdate: float = param(-1.0, unit="s", doc="process a scan after this time; <= 0 off")
    # filter
    resampleThreshold: float = param(0.5, lo=0.0, hi=1.0, doc="resample when Neff < this * particles")
    particles: int = param(30, lo=1, hi=10000, doc="number of particles")
    # map
    xmin: float = param(-100.0, unit="m", doc="initial map extent")
    ymin: float = param(-100.0, unit="m")
    xmax: float = param(100.0, unit="m")
    ymax: float = param(100.0, unit="m")
    delta: float = param(0.05, lo=0.005, hi=1.0, unit="m", doc="map resolution")
    map_update_interval: float = param(5.0, lo=0.0, unit="s", doc="how often the node publishes the map")
    # likelihood sampling of the original (accepted, unused: the proposal here is the correlative search)
    llsamplerange: float = param(0.01, lo=0.0, unit="m")
    llsamplestep: float = param(0.01, lo=0.0, unit="m")
    lasamplerange: float = param(0.005, lo=0.0, unit="rad")
    lasamplestep: float = param(0.005, lo=0.0, unit="rad")
    # zenav extras: coarse-to-fine correlative search before the hill climb
    search_linear: float = param(0.4, lo=0.0, hi=5.0, unit="m", doc="half-width of the xy search window")
    search_angular: float = param(0.15, lo=0.0, hi=1.5, unit="rad", doc="half-width of the angle window")
    match_sigma: float = param(0.05, lo=1e-3, hi=1.0, unit="m",
                               doc="std dev of the matching kernel exp(-d^2 / (2 match_sigma^2))")
    prior_weight: float = param(0.001, lo=0.0, doc="motion prior of the matcher: score per beam "
                                "lost per squared odometry standard deviation of deviation from the "
                                "odometry prediction (0 = off)")
    prior_sigma_xy: float = param(0.003, lo=1e-4, unit="m",
                                  doc="floor added to the motion model's translation std dev")
    prior_sigma_theta: float = param(0.02, lo=1e-4, unit="rad",
                                     doc="floor added to the motion model's rotation std dev")
    field_radius: int = param(4, lo=1, hi=20, unit="cells", doc="likelihood field support")
    seed: int = param(0, lo=0, doc="random seed")

    def validate(self) -> None:
        if self.xmax <= self.xmin or self.ymax <= self.ymin:
            raise ValueError("xmax/ymax must exceed xmin/ymin")

    @property
    def usable_range(self) -> float:
        return min(self.maxUrange, self.maxRange)


def load_gmapping(path: str | Path | None = None, section: str = "", **overrides) -> GMappingParams:
    """Load a gmapping YAML (node-only keys are accepted and ignored); ``overrides`` win."""
    return load_params_file(GMappingParams, path, section, overrides, ignore=NODE_ONLY)
