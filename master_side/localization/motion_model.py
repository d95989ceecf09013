"""ROS amcl's odometry motion models: ``diff`` (Probabilistic Robotics, sample_motion_model_odometry) and
``omni`` (``OmniMotionModel``, below).

An odometry increment is split into rotate (rot1), translate (trans), rotate (rot2); each particle
gets its own noisy copy. ``odom_alpha1``: rotation noise from rotation, ``odom_alpha2``: rotation from
translation, ``odom_alpha3``: translation from translation, ``odom_alpha4``: translation from rotation.
``diff`` reproduces ROS's original model, which uses the variance expression as the standard
deviation; ``diff-corrected`` takes its square root (so it wants much smaller alphas, ~0.005-0.05).
Rotations near ±π count as reversing, not turning (min of the angle to 0 and to π).
"""

from __future__ import annotations

import math

import numpy as np

from common.geometry import Pose2D, normalize_angle, normalize_angles

STILL_M = 0.01  # an increment shorter than this has no direction: rot1 is 0, all the turn is rot2


def _turn_noise(rot):
    """Rotation magnitude for the noise: a half turn is driving backwards, not turning (a float, or an
    array of them for odom_noise's fit)."""
    if np.ndim(rot) == 0:
        return min(abs(normalize_angle(rot)), abs(normalize_angle(rot - math.pi)))
    return np.minimum(np.abs(normalize_angles(rot)), np.abs(normalize_angles(rot - np.pi)))


class DiffMotionModel:
    def __init__(self, alpha1: float, alpha2: float, alpha3: float, alpha4: float,
                 corrected: bool = False) -> None:
        self.a1, self.a2, self.a3, self.a4 = alpha1, alpha2, alpha3, alpha4
        self.corrected = corrected

    def decompose(self, old: Pose2D, new: Pose2D) -> tuple[float, float, float]:
        """(rot1, trans, rot2) of the odometry increment from ``old`` to ``new`` (odom frame)."""
        dx, dy = new.x - old.x, new.y - old.y
        trans = math.hypot(dx, dy)
        rot1 = 0.0 if trans < STILL_M else normalize_angle(math.atan2(dy, dx) - old.theta)
        rot2 = normalize_angle(new.theta - old.theta - rot1)
        return rot1, trans, rot2

    def sigmas(self, rot1, trans, rot2) -> tuple:
        """Noise standard deviations of (rot1, trans, rot2): floats, or arrays of increments."""
        n1, n2 = _turn_noise(rot1), _turn_noise(rot2)
        v = (self.a1 * n1 * n1 + self.a2 * trans * trans,
             self.a3 * trans * trans + self.a4 * (n1 * n1 + n2 * n2),
             self.a1 * n2 * n2 + self.a2 * trans * trans)
        if not self.corrected:
            return v
        return tuple(math.sqrt(x) if np.ndim(x) == 0 else np.sqrt(x) for x in v)

    def sample(self, poses: np.ndarray, old: Pose2D, new: Pose2D, rng: np.random.Generator) -> np.ndarray:
        """Move every particle (N, 3) by the odometry increment old -> new with its own noise."""
        rot1, trans, rot2 = self.decompose(old, new)
        s1, st, s2 = self.sigmas(rot1, trans, rot2)
        n = len(poses)
        r1 = rot1 - rng.normal(0.0, 1.0, n) * s1
        tr = trans - rng.normal(0.0, 1.0, n) * st
        r2 = rot2 - rng.normal(0.0, 1.0, n) * s2
        heading = poses[:, 2] + r1
        return np.column_stack((poses[:, 0] + tr * np.cos(heading), poses[:, 1] + tr * np.sin(heading),
                                normalize_angles(heading + r2)))


class OmniMotionModel:
    """ROS amcl's ``omni`` model (amcl_odom.cpp, ODOM_MODEL_OMNI): the increment is a translation along its
    bearing and a rotation, and each particle also gets a sideways ("strafe") error. ``odom_alpha1``:
    translation and strafe noise from rotation, ``odom_alpha2``: rotation from translation, ``odom_alpha3``:
    translation from translation, ``odom_alpha4``: rotation from rotation, ``odom_alpha5``: strafe from
    translation. ``omni`` uses the variance expressions as standard deviations, as ROS's original does;
    ``omni-corrected`` their square roots.

    Not only for omnidirectional bases: a skid-steered base moves sideways while it turns (it pivots toward
    its more loaded axle, bench/turning.py) and its wheel odometry cannot see it; ``diff`` gives an in-place
    turn no sideways spread at all, this model a spread that grows with the turn."""

    def __init__(self, alpha1: float, alpha2: float, alpha3: float, alpha4: float, alpha5: float,
                 corrected: bool = False) -> None:
        self.a1, self.a2, self.a3, self.a4, self.a5 = alpha1, alpha2, alpha3, alpha4, alpha5
        self.corrected = corrected

    def sample(self, poses: np.ndarray, old: Pose2D, new: Pose2D, rng: np.random.Generator) -> np.ndarray:
        dx, dy = new.x - old.x, new.y - old.y
        trans2, rot = dx * dx + dy * dy, normalize_angle(new.theta - old.theta)
        s_trans = self.a3 * trans2 + self.a1 * rot * rot
        s_rot = self.a4 * rot * rot + self.a2 * trans2
        s_strafe = self.a1 * rot * rot + self.a5 * trans2
        if self.corrected:
            s_trans, s_rot, s_strafe = math.sqrt(s_trans), math.sqrt(s_rot), math.sqrt(s_strafe)
        n = len(poses)
        bearing = normalize_angle(math.atan2(dy, dx) - old.theta) + poses[:, 2]
        c, s = np.cos(bearing), np.sin(bearing)
        tr = math.sqrt(trans2) + rng.normal(0.0, 1.0, n) * s_trans
        rt = rot + rng.normal(0.0, 1.0, n) * s_rot
        st = rng.normal(0.0, 1.0, n) * s_strafe
        return np.column_stack((poses[:, 0] + tr * c + st * s, poses[:, 1] + tr * s - st * c,
                                normalize_angles(poses[:, 2] + rt)))
