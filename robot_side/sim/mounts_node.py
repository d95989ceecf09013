"""The simulated sensors' mounts in TF: the static transforms the sim node sends (laser, camera_link, depth
and optical frames) and, with ``mount_tf`` false, the camera_link -> depth frame edge that makes another
node's base_link -> camera_link agree with where the camera is rendered."""

from __future__ import annotations

import math
import threading

from common.geometry import OPTICAL_FROM_LINK, Transform
from common.messages import Header, TransformStamped
from common.tf import StaticTFBroadcaster, TFError, TFListener
from robot_side.sim.node_params import CAMERA_LINK, SimNodeParams
from robot_side.sim.simulator import Simulator


class SensorMounts:
    """The mounts of one simulated robot's sensors, sent on ``static`` stamped ``t0``."""

    def __init__(self, node, sim: Simulator, p: SimNodeParams, static: StaticTFBroadcaster, t0: float) -> None:
        self.node, self.sim, self.p, self.static, self.t0 = node, sim, p, static, t0

    def transforms(self, camera_link_to_depth: Transform | None = None) -> list[TransformStamped]:
        s, base, t0 = self.sim, self.sim.base.p.base_frame_id, self.t0
        out = []
        if s.laser and self.p.mount_tf:
            lp = s.laser.p
            out.append(TransformStamped(Header(t0, base), lp.frame_id,
                                        Transform.from_xyz_rpy(lp.x, lp.y, lp.z, 0.0, 0.0, lp.yaw)))
        if s.camera:
            cp, depth = s.camera.p, self.p.depth_frame_id
            mount = Transform.from_xyz_rpy(cp.x, cp.y, cp.z, 0.0, 0.0, cp.yaw)
            if self.p.mount_tf:
                out.append(TransformStamped(Header(t0, base), CAMERA_LINK, mount))
                out.append(TransformStamped(Header(t0, CAMERA_LINK), depth, Transform()))
            elif camera_link_to_depth is not None:
                out.append(TransformStamped(Header(t0, CAMERA_LINK), depth, camera_link_to_depth))
            out.append(TransformStamped(Header(t0, depth), cp.frame_id, OPTICAL_FROM_LINK))
        return out

    def follow(self, listener: TFListener, stop: threading.Event) -> None:
        """mount_tf false: base_link -> camera_link belongs to a static transform node. Publish
        camera_link -> camera_depth_frame so that base_link -> camera_depth_frame is the rendered mount;
        check a configured laser's edge against its mount (a warning: the sim cannot fix that one).
        Runs until ``stop`` is set (a thread of its own)."""
        s, base = self.sim, self.sim.base.p.base_frame_id
        last, laser_checked = None, s.laser is None
        while not stop.wait(0.2 if last is None else 1.0):
            buf = listener.buffer
            if s.camera:
                cp = s.camera.p
                try:
                    link = buf.lookup(base, CAMERA_LINK).transform
                    corr = link.inverse().compose(Transform.from_xyz_rpy(cp.x, cp.y, cp.z, 0.0, 0.0, cp.yaw))
                    if last is None or not same_transform(corr, last):
                        last = corr
                        self.static.send(self.transforms(corr))
                        self.node.log.info("%s -> %s is owned by another node; publishing %s -> %s to match "
                                           "the rendered camera", base, CAMERA_LINK, CAMERA_LINK,
                                           self.p.depth_frame_id)
                except TFError:
                    pass
            if not laser_checked:
                lp = s.laser.p
                try:
                    got = buf.lookup(base, lp.frame_id).transform
                    laser_checked = True
                    mount = Transform.from_xyz_rpy(lp.x, lp.y, lp.z, 0.0, 0.0, lp.yaw)
                    if not same_transform(got, mount, 1e-3):
                        self.node.log.warning("TF %s -> %s (%s) differs from the simulated laser mount x=%g "
                                              "y=%g z=%g yaw=%g", base, lp.frame_id, got, lp.x, lp.y, lp.z,
                                              lp.yaw)
                except TFError:
                    pass


def same_transform(a: Transform, b: Transform, tol: float = 1e-6) -> bool:
    """Equal up to ``tol`` (m for the translation, quaternion w for the rotation)."""
    d = a.inverse().compose(b)
    q = d.rotation
    return math.dist(d.translation.as_array(), (0, 0, 0)) < tol and abs(abs(q.w) - 1.0) < tol
