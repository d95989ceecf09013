"""One Rerun logging function per message type (our rviz displays).

Every function takes the recording stream, a stable entity path and the message; positions stay in
the message's own frame and are placed in the scene through Rerun's named coordinate frames, fed
from the ``tf`` / ``tf_static`` topics (parent/child frame names as in ROS).
"""

from __future__ import annotations

import numpy as np
import rerun as rr

from common import messages as m

COSTMAP_COLORMAP = rr.components.Colormap.RvizCostmap
MAP_COLORMAP = rr.components.Colormap.RvizMap


def _frame(header: m.Header) -> rr.CoordinateFrame:
    return rr.CoordinateFrame(header.frame_id or "map")


def _grid(rec, path: str, header, resolution: float, origin: m.Pose2D, data: np.ndarray, colormap,
          opacity: float, draw_order: float) -> None:
    h, w = data.shape
    rec.log(path, _frame(header), rr.GridMap(
        data=np.ascontiguousarray(data).view(np.uint8).tobytes(),
        format=rr.components.ImageFormat(width=w, height=h, color_model="L", channel_datatype="U8"),
        cell_size=resolution, translation=[origin.x, origin.y, 0.0],
        rotation_axis_angle=rr.RotationAxisAngle([0, 0, 1], origin.theta),
        colormap=colormap, opacity=opacity, draw_order=draw_order))


def log_occupancy_grid(rec, path: str, msg: m.OccupancyGrid) -> None:
    _grid(rec, path, msg.header, msg.resolution, msg.origin, msg.data, MAP_COLORMAP, 1.0, -10.0)


def log_costmap(rec, path: str, msg: m.Costmap) -> None:
    _grid(rec, path, msg.header, msg.resolution, msg.origin, msg.data, COSTMAP_COLORMAP, 0.6, -5.0)


def log_scan(rec, path: str, msg: m.LaserScan) -> None:
    r = msg.ranges.astype(np.float64)
    a = msg.angles()
    ok = np.isfinite(r) & (r >= msg.range_min) & (r <= msg.range_max)
    pts = np.column_stack((r[ok] * np.cos(a[ok]), r[ok] * np.sin(a[ok]), np.zeros(ok.sum())))
    rec.log(path, _frame(msg.header), rr.Points3D(pts, radii=0.02, colors=[255, 40, 40]))


def log_cloud(rec, path: str, msg: m.PointCloud, max_points: int = 20000) -> None:
    pts = msg.points
    if len(pts) > max_points:
        pts = pts[:: int(np.ceil(len(pts) / max_points))]
    z = pts[:, 2] if len(pts) else np.zeros(0)
    rec.log(path, _frame(msg.header), rr.Points3D(pts, radii=0.01, colors=_height_colors(z)))


def _height_colors(z: np.ndarray) -> np.ndarray:
    t = np.clip((z - z.min()) / (np.ptp(z) + 1e-9), 0, 1) if len(z) else z
    return np.column_stack((255 * t, 80 + 120 * (1 - t), 255 * (1 - t))).astype(np.uint8)


def log_depth_image(rec, path: str, msg: m.DepthImage) -> None:
    rec.log(path, rr.DepthImage(msg.depth, meter=1.0, colormap="Turbo"))


def log_path(rec, path: str, msg: m.Path, color=(40, 200, 40)) -> None:
    p = msg.poses
    strip = np.column_stack((p[:, 0], p[:, 1], np.full(len(p), 0.02))) if len(p) else np.zeros((0, 3))
    rec.log(path, _frame(msg.header), rr.LineStrips3D([strip], colors=[color], radii=0.015))


def log_polygon(rec, path: str, msg: m.PolygonStamped, color=(60, 120, 255)) -> None:
    p = msg.points.astype(np.float64)
    if len(p):
        p = np.vstack((p, p[:1]))
    strip = np.column_stack((p[:, 0], p[:, 1], np.full(len(p), 0.03))) if len(p) else np.zeros((0, 3))
    rec.log(path, _frame(msg.header), rr.LineStrips3D([strip], colors=[color], radii=0.01))


def log_pose(rec, path: str, msg: m.PoseStamped, color=(255, 0, 200), length: float = 0.5) -> None:
    p = msg.pose.to_pose2d()
    tip = [p.x + length * np.cos(p.theta), p.y + length * np.sin(p.theta), 0.05]
    rec.log(path, _frame(msg.header), rr.Arrows3D(origins=[[p.x, p.y, 0.05]], vectors=[np.subtract(tip, [p.x, p.y, 0.05])],
                                                  colors=[color], radii=0.03))


def log_transforms(rec, path: str, msg: m.TFMessage, static: bool = False, set_time=None) -> None:
    """Each edge at ``path/<child>``; ``set_time(stamp)`` positions it on the timeline."""
    for ts in msg.transforms:
        t, q = ts.transform.translation, ts.transform.rotation
        child = ts.child_frame_id.lstrip("/")
        if set_time is not None and not static:
            set_time(ts.header.stamp)
        rec.log(f"{path}/{child}", rr.Transform3D(
            translation=[t.x, t.y, t.z], quaternion=[q.x, q.y, q.z, q.w],
            parent_frame=ts.header.frame_id.lstrip("/"), child_frame=child), static=static)


class OdomTrail:
    """Accumulates odometry positions into a bounded trail."""

    def __init__(self, max_points: int = 5000, min_step: float = 0.02) -> None:
        self.points: list[tuple[float, float]] = []
        self.max_points, self.min_step = max_points, min_step

    def log(self, rec, path: str, msg: m.Odometry) -> None:
        p = msg.pose2d
        if self.points and np.hypot(p.x - self.points[-1][0], p.y - self.points[-1][1]) < self.min_step:
            return
        self.points.append((p.x, p.y))
        del self.points[: -self.max_points]
        arr = np.array(self.points)
        strip = np.column_stack((arr, np.full(len(arr), 0.01)))
        rec.log(path, _frame(msg.header), rr.LineStrips3D([strip], colors=[[250, 200, 0]], radii=0.01))


def log_twist(rec, path: str, msg: m.Twist) -> None:
    rec.log(f"{path}/linear_x", rr.Scalars(msg.linear.x))
    rec.log(f"{path}/angular_z", rr.Scalars(msg.angular.z))


def log_text(rec, path: str, text: str, level: str = "INFO") -> None:
    rec.log(path, rr.TextLog(text, level=level))
