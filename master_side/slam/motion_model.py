"""gmapping's odometry motion model: noise on the odometry increment, vectorised over particles."""

from __future__ import annotations

import numpy as np

from common.geometry import Pose2D, normalize_angles


def relative(old: Pose2D, new: Pose2D) -> np.ndarray:
    """Odometry increment ``old⁻¹ ⊕ new`` as (dx, dy, dtheta)."""
    return old.between(new).as_array()


def compose_many(poses: np.ndarray, delta: np.ndarray) -> np.ndarray:
    """poses (N, 3) ⊕ delta (N, 3) or (3,)."""
    c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    d = np.broadcast_to(delta, poses.shape)
    return np.column_stack((poses[:, 0] + c * d[:, 0] - s * d[:, 1],
                            poses[:, 1] + s * d[:, 0] + c * d[:, 1],
                            normalize_angles(poses[:, 2] + d[:, 2])))


class MotionModel:
    """srr/str: translation noise from translation/rotation; srt/stt: rotation noise (gmapping)."""

    def __init__(self, srr: float, srt: float, str_: float, stt: float):
        self.srr, self.srt, self.str_, self.stt = srr, srt, str_, stt

    def sigmas(self, delta: np.ndarray) -> np.ndarray:
        """Standard deviations of the (x, y, theta) noise for one increment (dx, dy, dtheta)."""
        dx, dy, dth = np.abs(delta)
        sxy = 0.3 * self.srr
        return np.array([self.srr * dx + self.str_ * dth + sxy * dy,
                         self.srr * dy + self.str_ * dth + sxy * dx,
                         self.stt * dth + self.srt * np.hypot(dx, dy)])

    def sample(self, poses: np.ndarray, delta: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Move every particle pose (N, 3) by the increment with independent noise."""
        noisy = delta[None, :] + rng.standard_normal(poses.shape) * self.sigmas(delta)[None, :]
        return compose_many(poses, noisy)
