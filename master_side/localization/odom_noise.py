"""Odometry noise measured, not guessed: amcl's ``odom_alpha1..4`` fitted to a log's odometry errors.

amcl's motion model (motion_model.py) needs to know how wrong the robot's odometry is. ROS's defaults (0.2
each) are a guess for an unknown robot; a user who has a log of the robot and a trustworthy trajectory
for it (SLAM's, ``zenav slam run``) can measure them instead, as the odometry calibration every robot needs.

The log is cut where amcl updates (the odometry moved ``update_min_d`` or turned ``update_min_a`` since the
last cut). Each piece is split into rotate / translate / rotate, for the odometry and for the reference
over the same stamps: the errors are those of the heading change and of the distance. The alphas are the
ones under which those errors are most likely, with the model's own standard deviations:
rot1, rot2: alpha1·rot² + alpha2·trans²; trans: alpha3·trans² + alpha4·(rot1² + rot2²) (``diff``, ROS's
original model, which uses these expressions as standard deviations), or their square roots
(``diff-corrected``). A systematic error (a wheel a little smaller than the other) counts as noise: amcl
has no other place for it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from common.geometry import normalize_angles
from master_side.localization.motion_model import STILL_M, DiffMotionModel


@dataclass(frozen=True)
class OdomNoise:
    alpha1: float
    alpha2: float
    alpha3: float
    alpha4: float
    model: str  # "diff" or "diff-corrected"
    pieces: int  # the odometry increments the fit saw
    heading_err_rms_deg: float  # of the heading change over a piece
    trans_err_rms_m: float

    def yaml(self) -> str:
        """The lines to put in amcl's parameters."""
        return "\n".join([f"odom_model_type: {self.model}"]
                         + [f"odom_alpha{k}: {getattr(self, f'alpha{k}'):.4g}" for k in range(1, 5)])


def decompose(old: np.ndarray, new: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(rot1, trans, rot2) of every increment old -> new ((N, 3) poses each): DiffMotionModel.decompose for
    many increments at once."""
    d = new[:, :2] - old[:, :2]
    trans = np.hypot(d[:, 0], d[:, 1])
    rot1 = np.where(trans < STILL_M, 0.0, normalize_angles(np.arctan2(d[:, 1], d[:, 0]) - old[:, 2]))
    rot2 = normalize_angles(new[:, 2] - old[:, 2] - rot1)
    return rot1, trans, rot2


def cuts(odom: np.ndarray, min_d: float, min_a: float) -> np.ndarray:
    """Indices where amcl would update: the first pose, then each one ``min_d`` moved or ``min_a`` turned
    from the last cut (odometry frame)."""
    out, last = [0], odom[0]
    for i in range(1, len(odom)):
        p = odom[i]
        if math.hypot(p[0] - last[0], p[1] - last[1]) >= min_d or \
                abs(math.remainder(p[2] - last[2], 2 * math.pi)) >= min_a:
            out.append(i)
            last = p
    return np.asarray(out)


def errors(odom: np.ndarray, ref: np.ndarray, min_d: float = 0.2,
           min_a: float = math.pi / 6) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per piece: the odometry's (rot1, trans, rot2), the error of its heading change and of its trans.

    ``odom`` and ``ref``: (N, 3) poses at the same N stamps (the odometry frame, the reference's own frame).
    The heading change (rot1 + rot2), not rot1 and rot2 each: over a piece that is mostly a turn in place,
    the direction of a few centimetres of travel (rot1) is noise of the reference itself (intel: 13° rms
    that way, 1.9° for the heading)."""
    if odom.shape != ref.shape or odom.ndim != 2 or odom.shape[1] != 3:
        raise ValueError(f"odometry {odom.shape} and reference {ref.shape} must both be (N, 3) at the same stamps")
    k = cuts(odom, min_d, min_a)
    if len(k) < 3:
        raise ValueError(f"the odometry moves too little: {len(k) - 1} increments of {min_d} m / "
                         f"{math.degrees(min_a):.0f} deg")
    o1, ot, o2 = decompose(odom[k[:-1]], odom[k[1:]])
    _, rt, _ = decompose(ref[k[:-1]], ref[k[1:]])
    e_heading = normalize_angles(np.diff(ref[k, 2]) - np.diff(odom[k, 2]))
    return o1, ot, o2, e_heading, rt - ot


def _fit(sigma, err: np.ndarray) -> tuple[float, float]:
    """a, b maximising the likelihood of ``err`` ~ N(0, sigma(a, b))."""
    floor = 1e-9  # a standard deviation of zero (a piece with no motion) makes any error impossible

    def nll(logs: np.ndarray) -> float:
        s = np.maximum(sigma(*np.exp(logs)), floor)
        return float(np.sum(np.log(s) + 0.5 * (err / s) ** 2))

    best = None
    for start in ((-2.0, -2.0), (-6.0, 0.0), (0.0, -6.0)):  # a few starts: the two terms can trade places
        r = minimize(nll, np.array(start), method="L-BFGS-B", bounds=[(-25.0, 8.0)] * 2)
        if best is None or r.fun < best.fun:
            best = r
    a, b = np.exp(best.x)
    return float(a), float(b)


def fit(odom: np.ndarray, ref: np.ndarray, model: str = "diff", min_d: float = 0.2,
        min_a: float = math.pi / 6) -> OdomNoise:
    """The odometry noise of ``odom`` against ``ref`` ((N, 3) each, the same stamps) for amcl's ``model``
    with amcl's ``update_min_d`` / ``update_min_a``."""
    if model not in ("diff", "diff-corrected"):
        raise ValueError(f"model {model!r}: diff or diff-corrected (the omni models are not fitted)")
    o1, ot, o2, e_head, e_tr = errors(odom, ref, min_d, min_a)
    corrected = model == "diff-corrected"

    def heading_sd(a: float, b: float) -> np.ndarray:
        # the heading change is rot1 + rot2, two independent draws: its deviation is the root of their squares
        s1, _, s2 = DiffMotionModel(a, b, 0.0, 0.0, corrected).sigmas(o1, ot, o2)
        return np.hypot(s1, s2)

    a1, a2 = _fit(heading_sd, e_head)
    a3, a4 = _fit(lambda a, b: DiffMotionModel(0.0, 0.0, a, b, corrected).sigmas(o1, ot, o2)[1], e_tr)
    return OdomNoise(a1, a2, a3, a4, model, len(ot), math.degrees(float(np.sqrt(np.mean(e_head**2)))),
                     float(np.sqrt(np.mean(e_tr**2))))
