"""One Rerun logging function per message type (our rviz displays).

Every function takes the recording stream, a stable entity path and the message; positions stay in
the message's own frame and are placed in the scene through Rerun's named coordinate frames, fed
from the ``tf`` / ``tf_static`` topics (parent/child frame names as in ROS).
"""

from __future__ import annotations

import numpy as np
import rerun as rr

from common import messages as m
from common.geometry import Transform

COSTMAP_COLORMAP = rr.components.Colormap.RvizCostmap
MAP_COLORMAP = rr.components.Colormap.RvizMap


def aligned(a: np.ndarray, dtype=None) -> np.ndarray:
    """A C-contiguous, *aligned* array. Decoded message arrays are views into the payload and may be
    misaligned; handing such a buffer to Rerun aborts the process (a Rust panic in arrow), so every
    array from a message goes through here before ``rec.log``."""
    return np.require(a, dtype=dtype, requirements=["C", "A"])


def frame_name(frame_id: str, default: str = "map") -> str:
    """A ROS frame id as a Rerun frame name ('/odom' -> 'odom'; empty -> ``default``)."""
    return frame_id.strip().lstrip("/") or default


class Prefixed:
    """A recording stream whose entity paths and frame names start with ``<prefix>/`` (one robot of
    several side by side: ``robot1/world/map`` in frame ``robot1/map``); everything else is the stream's."""

    def __init__(self, rec, prefix: str) -> None:
        self._rec, self.prefix, self.frame_prefix = rec, prefix, prefix + "/"

    def log(self, path: str, *args, **kwargs) -> None:
        self._rec.log(f"{self.prefix}/{path}", *args, **kwargs)

    def __getattr__(self, name: str):
        return getattr(self._rec, name)


def frame_of(rec, frame_id: str, default: str = "map") -> str:
    """The Rerun frame name of ``frame_id`` in ``rec`` (with a ``Prefixed`` stream's robot prefix)."""
    return getattr(rec, "frame_prefix", "") + frame_name(frame_id, default)


def _frame(rec, header: m.Header) -> rr.CoordinateFrame:
    return rr.CoordinateFrame(frame_of(rec, header.frame_id))


def grid_image(data: np.ndarray) -> np.ndarray:
    """A ROS grid (row 0 = the lowest y, at the origin) in Rerun's GridMap order: image rows, row 0 at the
    top (the highest y). Rerun places the image's lower-left corner at ``translation`` and draws row 0 at
    the far edge along +y (``re_view_spatial`` grid_map.rs: top-left = (0, height * cell_size)); logging the
    ROS rows as they are mirrors the map top to bottom (checked in the web viewer:
    tests/monitor/test_monitor_not_mirrored.py)."""
    return aligned(data[::-1]).view(np.uint8)


def _grid(rec, path: str, header, resolution: float, origin: m.Pose2D, data: np.ndarray, colormap,
          opacity: float, draw_order: float) -> None:
    h, w = data.shape
    rec.log(path, _frame(rec, header), rr.GridMap(
        data=grid_image(data).tobytes(),
        format=rr.components.ImageFormat(width=w, height=h, color_model="L", channel_datatype="U8"),
        cell_size=resolution, translation=[origin.x, origin.y, 0.0],
        rotation_axis_angle=rr.RotationAxisAngle([0, 0, 1], origin.theta),
        colormap=colormap, opacity=opacity, draw_order=draw_order))


def log_occupancy_grid(rec, path: str, msg: m.OccupancyGrid) -> None:
    """The map, cut to its known part (and a cell around it): SLAM's 100 m grid is mostly unknown, and
    its 4 MB a frame were most of what a browser's viewer had to take in while exploring."""
    data, origin = known_part(msg.data, msg.origin, msg.resolution)
    _grid(rec, path, msg.header, msg.resolution, origin, data, MAP_COLORMAP, 1.0, -10.0)


def known_part(data: np.ndarray, origin: m.Pose2D, res: float) -> tuple[np.ndarray, m.Pose2D]:
    """``data`` cut to the rows and columns holding known cells (all of it when none is known), and the
    origin of that part (the grid's rotation kept)."""
    known = data >= 0
    rows, cols = np.nonzero(known.any(axis=1))[0], np.nonzero(known.any(axis=0))[0]
    if len(rows) == 0:
        return data, origin
    r0, c0 = max(rows[0] - 1, 0), max(cols[0] - 1, 0)
    r1, c1 = min(rows[-1] + 2, data.shape[0]), min(cols[-1] + 2, data.shape[1])
    if (r0, c0, r1, c1) == (0, 0, *data.shape):
        return data, origin
    return data[r0:r1, c0:c1], origin.compose(m.Pose2D(c0 * res, r0 * res, 0.0))


def log_costmap(rec, path: str, msg: m.Costmap) -> None:
    _grid(rec, path, msg.header, msg.resolution, msg.origin, msg.data, COSTMAP_COLORMAP, 0.6, -5.0)


def scan_points(msg: m.LaserScan) -> np.ndarray:
    """(N, 3) end points of the valid returns (finite, within range_min..range_max), laser frame."""
    r = msg.ranges.astype(np.float64)
    a = msg.angles()
    ok = np.isfinite(r) & (r >= msg.range_min) & (r <= msg.range_max)
    return np.column_stack((r[ok] * np.cos(a[ok]), r[ok] * np.sin(a[ok]), np.zeros(ok.sum())))


Fixed = tuple[str, Transform]  # (a fixed frame, the transform from the sensor's frame into it: placement.py)


def _placed(rec, header: m.Header, pts: np.ndarray, fixed: Fixed | None) -> tuple[rr.CoordinateFrame, np.ndarray]:
    """Sensor points placed as rviz places them: in the fixed frame, through the transform *at their stamp*.
    In their own frame, Rerun would move them with the newest transform it has (scans and TF are throttled
    separately, so a scan taken while turning was drawn rotated by up to a TF period's turn)."""
    if fixed is None:
        return _frame(rec, header), pts
    frame, tf = fixed
    return rr.CoordinateFrame(frame_of(rec, frame)), aligned(tf.apply(pts), np.float32)


def log_scan(rec, path: str, msg: m.LaserScan, fixed: Fixed | None = None) -> None:
    frame, pts = _placed(rec, msg.header, scan_points(msg), fixed)
    rec.log(path, frame, rr.Points3D(pts, radii=0.03, colors=[255, 40, 40]))


def log_cloud(rec, path: str, msg: m.PointCloud, max_points: int = 20000, fixed: Fixed | None = None) -> None:
    pts = aligned(msg.points, np.float32)
    if len(pts) > max_points:
        pts = aligned(pts[:: int(np.ceil(len(pts) / max_points))])
    z = pts[:, 2] if len(pts) else np.zeros(0)
    frame, pts = _placed(rec, msg.header, pts, fixed)
    rec.log(path, frame, rr.Points3D(pts, radii=0.01, colors=_height_colors(z)))


def _height_colors(z: np.ndarray) -> np.ndarray:
    t = np.clip((z - z.min()) / (np.ptp(z) + 1e-9), 0, 1) if len(z) else z
    return np.column_stack((255 * t, 80 + 120 * (1 - t), 255 * (1 - t))).astype(np.uint8)


def log_depth_image(rec, path: str, msg: m.DepthImage) -> None:
    rec.log(path, rr.DepthImage(aligned(msg.depth, np.float32), meter=1.0, colormap="Turbo"))


def log_path(rec, path: str, msg: m.Path, color=(40, 200, 40)) -> None:
    p = msg.poses
    strip = np.column_stack((p[:, 0], p[:, 1], np.full(len(p), 0.02))) if len(p) else np.zeros((0, 3))
    rec.log(path, _frame(rec, msg.header), rr.LineStrips3D([strip], colors=[color], radii=0.015))


def log_polygon(rec, path: str, msg: m.PolygonStamped, color=(60, 120, 255)) -> None:
    p = msg.points.astype(np.float64)
    if len(p):
        p = np.vstack((p, p[:1]))
    strip = np.column_stack((p[:, 0], p[:, 1], np.full(len(p), 0.03))) if len(p) else np.zeros((0, 3))
    rec.log(path, _frame(rec, msg.header), rr.LineStrips3D([strip], colors=[color], radii=0.02))


def log_pose(rec, path: str, msg: m.PoseStamped, color=(255, 0, 200), length: float = 0.5) -> None:
    p = msg.pose.to_pose2d()
    vec = [length * np.cos(p.theta), length * np.sin(p.theta), 0.0]
    rec.log(path, _frame(rec, msg.header), rr.Arrows3D(origins=[[p.x, p.y, 0.05]], vectors=[vec],
                                                  colors=[color], radii=0.03))


def log_robot_marker(rec, path: str, base_frame: str = "base_link") -> None:
    """A small marker at the robot's base frame (static): the map view's camera follows this entity."""
    rec.log(path, rr.CoordinateFrame(frame_of(rec, base_frame)), rr.Points3D([[0.0, 0.0, 0.05]], radii=0.04,
                                                              colors=[[60, 120, 255]]), static=True)


def ellipse_strip(centre, axes, angle: float, n: int = 48) -> np.ndarray:
    t = np.linspace(0, 2 * np.pi, n + 1)
    c, s = np.cos(angle), np.sin(angle)
    ex, ey = axes[0] * np.cos(t), axes[1] * np.sin(t)
    return np.column_stack((centre[0] + c * ex - s * ey, centre[1] + s * ex + c * ey, np.full(n + 1, 0.04)))


def log_particles(rec, path: str, msg: m.Path, max_arrows: int = 400) -> None:
    """AMCL's particle cloud (``Path`` rows x, y, yaw) as short arrows, and the 2-sigma covariance
    ellipse of their positions at ``path/covariance``."""
    from deploy.monitor.webstate import covariance_ellipse

    p = np.asarray(msg.poses, np.float64)
    if len(p) > max_arrows:
        p = p[:: int(np.ceil(len(p) / max_arrows))]
    origins = np.column_stack((p[:, 0], p[:, 1], np.full(len(p), 0.03))) if len(p) else np.zeros((0, 3))
    vecs = np.column_stack((0.15 * np.cos(p[:, 2]), 0.15 * np.sin(p[:, 2]), np.zeros(len(p)))) if len(p) \
        else np.zeros((0, 3))
    rec.log(path, _frame(rec, msg.header), rr.Arrows3D(origins=origins, vectors=vecs, colors=[[255, 60, 60]],
                                                  radii=0.008))
    ell = covariance_ellipse(np.asarray(msg.poses, np.float64)[:, :2]) if len(msg.poses) > 1 else None
    strips = [] if ell is None else [ellipse_strip(*ell)]
    rec.log(f"{path}/covariance", _frame(rec, msg.header), rr.LineStrips3D(strips, colors=[[255, 140, 0]], radii=0.02))


def log_transform(rec, path: str, ts: m.TransformStamped, static: bool = False) -> None:
    """One TF edge. Rerun's default relation is ROS's: the pose of ``child_frame`` in ``parent_frame``
    (maps child coordinates into the parent). Each child frame must always be logged at the same entity,
    so the caller uses ``tf/<child>``."""
    t, q = ts.transform.translation, ts.transform.rotation
    rec.log(path, rr.Transform3D(
        translation=[t.x, t.y, t.z], quaternion=rr.Quaternion(xyzw=[q.x, q.y, q.z, q.w]),
        parent_frame=frame_of(rec, ts.header.frame_id), child_frame=frame_of(rec, ts.child_frame_id)),
        static=static)


class OdomTrail:
    """The odometry trail as line-strip segments ``path/<k>`` of at most ``segment`` points.

    Re-logging one ever-growing strip would store O(n^2) points over a run; a finished segment is never
    logged again (it stays visible as the latest value of its entity), so each update costs at most
    ``segment`` points and the whole run O(n). A new point is taken every ``min_step`` metres.
    """

    def __init__(self, segment: int = 100, min_step: float = 0.05) -> None:
        self.points: list[tuple[float, float]] = []
        self.segment, self.min_step, self.index = segment, min_step, 0
        self.stamp: float | None = None
        self.restarted = False  # set by restart(): the odometry's source started again

    def restart(self) -> None:
        """The odometry's source started again (a driver or simulator restarted, as in `zenav demo` between
        worlds): its odom frame has nothing to do with the old trail's, which the next point empties."""
        self.restarted = True

    def log(self, rec, path: str, msg: m.Odometry) -> bool:
        p, stamp = msg.pose2d, msg.header.stamp
        if self.restarted or (self.stamp is not None and stamp < self.stamp):  # (or a simulated clock went back)
            for k in range(self.index + 1):  # emptied, not cleared: a Clear drops the entity's frame too, and
                rec.log(f"{path}/{k}", _frame(rec, msg.header), rr.LineStrips3D([]))  # Rerun reports it unplaced
            self.points, self.index, self.restarted = [], self.index + (1 if self.points else 0), False
        self.stamp = stamp
        if self.points and np.hypot(p.x - self.points[-1][0], p.y - self.points[-1][1]) < self.min_step:
            return False
        self.points.append((p.x, p.y))
        arr = np.array(self.points)
        strip = np.column_stack((arr, np.full(len(arr), 0.01)))
        rec.log(f"{path}/{self.index}", _frame(rec, msg.header),
                rr.LineStrips3D([strip], colors=[[250, 200, 0]], radii=0.015))
        if len(self.points) >= self.segment:  # start the next segment where this one ends
            self.points, self.index = self.points[-1:], self.index + 1
        return True


def log_twist(rec, path: str, msg: m.Twist) -> None:
    rec.log(f"{path}/linear_x", rr.Scalars(msg.linear.x))
    rec.log(f"{path}/angular_z", rr.Scalars(msg.angular.z))


def log_text(rec, path: str, text: str, level: str = "INFO") -> None:
    rec.log(path, rr.TextLog(text, level=level))
