"""The laser and the depth camera of the MuJoCo engine: rays cast by ``mujoco.mj_multiRay`` from the
sensor's 3D pose on the moving body (pitch and roll included) against the world's geoms and the
floor. Range limits, noise and message layout are the kinematic engine's (``Laser``, ``DepthCamera``):
only how a noise-free range is found differs.
"""

from __future__ import annotations

import math

import numpy as np

from common.geometry import OPTICAL_FROM_LINK, Pose2D
from robot_side.sim.depth_camera import DepthCamera, DepthCameraParams
from robot_side.sim.laser import Laser, LaserParams
from robot_side.sim.mujoco_base import MujocoBase
from robot_side.sim.mujoco_scene import FLOOR_GROUP, OBSTACLE_GROUP

__all__ = ["RayLaser", "RayDepthCamera"]

_GROUPS = np.zeros(6, np.uint8)
_GROUPS[[OBSTACLE_GROUP, FLOOR_GROUP]] = 1  # never the robot's own geoms


def _rz(yaw: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


class _Rays:
    """Cast unit directions given in a sensor frame mounted at (x, y, z, yaw) on the base."""

    def __init__(self, base: MujocoBase, mount: tuple[float, float, float, float], dirs: np.ndarray):
        self.base = base
        self.offset = np.array(mount[:3], float)
        self.rot = _rz(mount[3])
        self.dirs = np.ascontiguousarray(dirs, float)   # (n, 3) in the sensor frame
        n = len(dirs)
        self.geom = np.zeros(n, np.int32)
        self.dist = np.zeros(n, np.float64)

    def cast(self, cutoff: float) -> np.ndarray:
        """Distance along each ray to the first geom (+inf for none within ``cutoff``)."""
        pos, rot = self.base.frame3d()
        world = rot @ self.rot
        origin = pos + rot @ self.offset
        vec = (self.dirs @ world.T).ravel()
        sc = self.base.scene
        self.base.mj.mj_multiRay(sc.model, sc.data, origin, vec, _GROUPS, 1, -1, self.geom, self.dist, None,
                                 len(self.dist), cutoff)
        out = self.dist.copy()
        out[(self.geom < 0) | (out < 0) | (out > cutoff)] = np.inf
        return out


class RayLaser(Laser):
    """A planar laser on the MuJoCo body (``robot`` arguments are ignored: the body's pose is used)."""

    def __init__(self, base: MujocoBase, params: LaserParams):
        self.base = base
        super().__init__(base.world, params)
        a = self.angles
        self.rays = _Rays(base, (params.x, params.y, params.z, params.yaw),
                          np.column_stack((np.cos(a), np.sin(a), np.zeros_like(a))))

    def refresh(self) -> None:  # rays see the model as it is; nothing to precompute
        pass

    def ranges_exact(self, robot: Pose2D | None = None) -> np.ndarray:
        return self.rays.cast(self.p.range_max)


class RayDepthCamera(DepthCamera):
    """A depth camera on the MuJoCo body: one ray per pixel through the optical centre."""

    def __init__(self, base: MujocoBase, params: DepthCameraParams):
        self.base = base
        super().__init__(base.world, params)
        u, v = np.meshgrid(np.arange(self.width), np.arange(self.height))
        d_opt = np.stack(((u - self.cx) / self.fx, (v - self.cy) / self.fy, np.ones(u.shape)), axis=-1).reshape(-1, 3)
        norm = np.linalg.norm(d_opt, axis=1)
        self._z_of_unit = 1.0 / norm                      # depth (optical z) per metre along the ray
        link_from_opt = OPTICAL_FROM_LINK.as_matrix()[:3, :3]
        self.rays = _Rays(base, (params.x, params.y, params.z, params.yaw), (d_opt / norm[:, None]) @ link_from_opt.T)

    def refresh(self) -> None:
        pass

    def depth_exact(self, robot: Pose2D | None = None) -> np.ndarray:
        # farthest ray length a valid pixel can need: range_max at the image's corner
        reach = self.p.range_max / float(self._z_of_unit.min())
        dist = self.rays.cast(reach)
        return (dist * self._z_of_unit).astype(np.float32).reshape(self.height, self.width)

