"""Pose types with compose / inverse: Pose2D for the plane, Transform (quaternion) for 3D; angle
wrapping and the point-in-polygon test every footprint check uses (costmaps, planners, collision
monitor, simulator).

Both pose types are frozen dataclasses and also bus messages (registered in ``common.messages``).
Conventions follow ROS/REP-103: x forward, y left, z up, angles in radians, quaternions (x, y, z, w).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def normalize_angle(a: float) -> float:
    """Wrap an angle to [-pi, pi)."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def normalize_angles(a: np.ndarray) -> np.ndarray:
    """Vectorised ``normalize_angle``."""
    return (a + np.pi) % (2.0 * np.pi) - np.pi


def points_in_polygon(x: np.ndarray, y: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Even-odd rule for many points at once: ``x``/``y`` any same shape, ``poly`` (K, 2) vertices in
    order; loops over the polygon's few edges, vectorised over the points."""
    inside = np.zeros(np.shape(x), bool)
    xj, yj = poly[-1]
    for xi, yi in poly:
        cross = (yi > y) != (yj > y)
        with np.errstate(divide="ignore", invalid="ignore"):
            xint = (xj - xi) * (y - yi) / (yj - yi) + xi
        inside ^= cross & (x < xint)
        xj, yj = xi, yi
    return inside


def footprint_radii(footprint: np.ndarray) -> tuple[float, float]:
    """(inscribed, circumscribed) radius of a footprint polygon (K, 2) around the robot's origin: the
    nearest point of its outline and its farthest vertex (costmap_2d's calculateMinAndMaxDistances)."""
    fp = np.asarray(footprint, dtype=float).reshape(-1, 2)
    if len(fp) == 0:
        return 0.0, 0.0
    return float(distance_to_outline(np.zeros((1, 2)), fp)[0]), float(np.max(np.hypot(fp[:, 0], fp[:, 1])))


def distance_to_outline(points: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Distance of each point (N, 2) to the nearest edge of the closed polygon (K, 2)."""
    a = poly[None, :, :]
    ab = np.roll(poly, -1, axis=0)[None, :, :] - a
    ap = points[:, None, :] - a
    t = np.clip((ap * ab).sum(-1) / np.maximum((ab * ab).sum(-1), 1e-12), 0.0, 1.0)
    return np.hypot(*(ap - t[..., None] * ab).transpose(2, 0, 1)).min(axis=1)


@dataclass(frozen=True)
class Vector3:
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0

    def as_array(self) -> np.ndarray:
        return np.array([self.x, self.y, self.z])


@dataclass(frozen=True)
class Quaternion:
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    w: float = 1.0

    @staticmethod
    def from_yaw(yaw: float) -> Quaternion:
        return Quaternion(0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0))

    @staticmethod
    def from_euler(roll: float, pitch: float, yaw: float) -> Quaternion:
        """Fixed-axis roll (x), pitch (y), yaw (z), applied in that order (ROS RPY)."""
        cr, sr = math.cos(roll / 2), math.sin(roll / 2)
        cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
        cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
        return Quaternion(
            sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
            cr * cp * cy + sr * sp * sy,
        )

    def to_euler(self) -> tuple[float, float, float]:
        """Return (roll, pitch, yaw)."""
        x, y, z, w = self.x, self.y, self.z, self.w
        roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
        sinp = max(-1.0, min(1.0, 2 * (w * y - z * x)))
        pitch = math.asin(sinp)
        yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
        return roll, pitch, yaw

    @property
    def yaw(self) -> float:
        return self.to_euler()[2]

    def normalized(self) -> Quaternion:
        n = math.sqrt(self.x**2 + self.y**2 + self.z**2 + self.w**2)
        if n == 0.0:
            raise ValueError("zero-length quaternion")
        return Quaternion(self.x / n, self.y / n, self.z / n, self.w / n)

    def __mul__(self, o: Quaternion) -> Quaternion:
        return Quaternion(
            self.w * o.x + self.x * o.w + self.y * o.z - self.z * o.y,
            self.w * o.y - self.x * o.z + self.y * o.w + self.z * o.x,
            self.w * o.z + self.x * o.y - self.y * o.x + self.z * o.w,
            self.w * o.w - self.x * o.x - self.y * o.y - self.z * o.z,
        )

    def conjugate(self) -> Quaternion:
        return Quaternion(-self.x, -self.y, -self.z, self.w)

    def as_matrix(self) -> np.ndarray:
        x, y, z, w = self.x, self.y, self.z, self.w
        return np.array(
            [
                [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
            ]
        )

    def as_array(self) -> np.ndarray:
        return np.array([self.x, self.y, self.z, self.w])


def slerp(q0: Quaternion, q1: Quaternion, t: float) -> Quaternion:
    """Spherical interpolation, shortest arc, t in [0, 1]."""
    a, b = q0.as_array(), q1.as_array()
    dot = float(np.dot(a, b))
    if dot < 0.0:
        b, dot = -b, -dot
    if dot > 0.9995:
        r = a + t * (b - a)
    else:
        th = math.acos(dot)
        r = (math.sin((1 - t) * th) * a + math.sin(t * th) * b) / math.sin(th)
    r = r / np.linalg.norm(r)
    return Quaternion(*map(float, r))


@dataclass(frozen=True)
class Pose2D:
    """A planar pose (x, y in metres, theta in radians); also a 2D rigid transform."""

    x: float = 0.0
    y: float = 0.0
    theta: float = 0.0

    def compose(self, other: Pose2D) -> Pose2D:
        """self ⊕ other: ``other`` expressed in self's frame, returned in self's parent frame."""
        c, s = math.cos(self.theta), math.sin(self.theta)
        return Pose2D(
            self.x + c * other.x - s * other.y,
            self.y + s * other.x + c * other.y,
            normalize_angle(self.theta + other.theta),
        )

    def inverse(self) -> Pose2D:
        c, s = math.cos(self.theta), math.sin(self.theta)
        return Pose2D(-c * self.x - s * self.y, s * self.x - c * self.y, normalize_angle(-self.theta))

    def between(self, other: Pose2D) -> Pose2D:
        """self⁻¹ ⊕ other: ``other`` expressed in self's frame."""
        return self.inverse().compose(other)

    def apply(self, points: np.ndarray) -> np.ndarray:
        """Transform (N, 2) points from this pose's frame into its parent frame."""
        c, s = math.cos(self.theta), math.sin(self.theta)
        p = np.asarray(points, dtype=float)
        return np.column_stack((self.x + c * p[:, 0] - s * p[:, 1], self.y + s * p[:, 0] + c * p[:, 1]))

    def distance(self, other: Pose2D) -> float:
        return math.hypot(other.x - self.x, other.y - self.y)

    def as_array(self) -> np.ndarray:
        return np.array([self.x, self.y, self.theta])

    def to_transform(self) -> Transform:
        return Transform(Vector3(self.x, self.y, 0.0), Quaternion.from_yaw(self.theta))


def pivoted(d: Pose2D, center_x: float) -> Pose2D:
    """The relative motion ``d`` of a base that turns about the point (``center_x``, 0) of base_link, where ``d``
    was integrated as if it turned about base_link (as wheel odometry does). A turn by a about (c, 0) also moves
    base_link by (c (1 - cos a), -c sin a) in its frame before the turn; exact for a constant twist (its
    effect is linear in the twist). A skid-steered base pivots toward its more loaded axle
    (``python bench/turning.py``)."""
    if not center_x:
        return d
    a = d.theta
    return Pose2D(d.x + center_x * (1.0 - math.cos(a)), d.y - center_x * math.sin(a), a)


@dataclass(frozen=True)
class Transform:
    """A 3D rigid transform / pose: translation then rotation (parent ← child)."""

    translation: Vector3 = Vector3()
    rotation: Quaternion = Quaternion()

    @staticmethod
    def from_xyz_rpy(x: float, y: float, z: float, roll: float, pitch: float, yaw: float) -> Transform:
        return Transform(Vector3(x, y, z), Quaternion.from_euler(roll, pitch, yaw))

    def compose(self, other: Transform) -> Transform:
        t = self.rotation.as_matrix() @ other.translation.as_array() + self.translation.as_array()
        return Transform(Vector3(*map(float, t)), (self.rotation * other.rotation).normalized())

    def inverse(self) -> Transform:
        qi = self.rotation.conjugate()
        t = -(qi.as_matrix() @ self.translation.as_array())
        return Transform(Vector3(*map(float, t)), qi)

    def apply(self, points: np.ndarray) -> np.ndarray:
        """Transform (N, 3) points from the child frame into the parent frame."""
        p = np.asarray(points)
        r = self.rotation.as_matrix().astype(p.dtype if p.dtype.kind == "f" else float)
        return p @ r.T + self.translation.as_array().astype(r.dtype)

    def as_matrix(self) -> np.ndarray:
        m = np.eye(4)
        m[:3, :3] = self.rotation.as_matrix()
        m[:3, 3] = self.translation.as_array()
        return m

    def to_pose2d(self) -> Pose2D:
        """Project onto the plane (x, y, yaw)."""
        return Pose2D(self.translation.x, self.translation.y, self.rotation.yaw)


# In ROS a Pose and a Transform carry the same data; zenav uses one type for both.
Pose = Transform


class TurnCounter:
    """How far a heading has turned, all turns counted (|wrap(yaw_k - yaw_k-1)| summed), since ``reset``.
    The in-place spin checks of move_base (max_in_place_rotation) and of the trajectory planner (a full
    revolution without moving) count with it; each decides itself what resets the count."""

    def __init__(self) -> None:
        self.turned = 0.0
        self._yaw: float | None = None

    def reset(self) -> None:
        self.turned, self._yaw = 0.0, None

    def add(self, yaw: float) -> float:
        """Count the turn from the last heading to ``yaw`` (nothing for the first one); the total."""
        if self._yaw is not None:
            self.turned += abs(normalize_angle(yaw - self._yaw))
        self._yaw = float(yaw)
        return self.turned


# REP-103's camera convention: a camera's link frame (x forward, y left, z up) <- its optical frame
# (z forward, x right, y down). The Kinect driver and the simulated depth camera both publish it.
OPTICAL_FROM_LINK = Transform.from_xyz_rpy(0.0, 0.0, 0.0, -math.pi / 2, 0.0, -math.pi / 2)
