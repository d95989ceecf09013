"""What move_base reads before each control cycle, in words when it is unusable: the robot's pose in the
global and local frames from TF (with the age check of ROS's ``transform_tolerance``), and whether the
robot's own collision monitor is overriding our commands."""

from __future__ import annotations

from common.geometry import Pose2D
from common.tf_buffer import TFBuffer


def robot_pose(buffer: TFBuffer, global_frame: str | None, local_frame: str, base_frame: str, tol: float,
               now: float):
    """(global pose, local pose, local_from_global, problem); the first three are None with a problem."""
    if global_frame is None:
        return None, None, None, "no global costmap received yet"
    try:
        g = buffer.lookup(global_frame, base_frame, 0.0)
        lo = buffer.lookup(local_frame, base_frame, 0.0)
        lg = buffer.lookup_pose2d(local_frame, global_frame, 0.0)
    except Exception as e:  # noqa: BLE001 - any TF problem is the reason not to move
        # the edge that went quiet is the cause to name (seen: map -> odom 293 s old after a healed link,
        # reported only as an extrapolation on odom -> base_link)
        return None, None, None, f"no robot pose: {e}{slowest_edge(buffer, now)}"
    for ts, a, b in ((g, global_frame, base_frame), (lo, local_frame, base_frame)):
        age = now - ts.header.stamp
        if ts.header.stamp > 0 and age > tol:
            return None, None, None, (f"stale TF: {a} <- {b} is {age:.2f} s old (transform_tolerance "
                                      f"{tol:.2f} s){slowest_edge(buffer, now)}")
    pose: Pose2D = g.transform.to_pose2d()
    return pose, lo.transform.to_pose2d(), lg, ""


def slowest_edge(buffer: TFBuffer, now: float) -> str:
    """'; oldest edge parent -> child (age, from publisher)' among the non-static TF edges, or ''."""
    edges = [e for e in buffer.edges() if not e.static]
    if not edges:
        return ""
    e = max(edges, key=lambda e: now - e.latest_stamp)
    return f"; oldest edge {e.parent} -> {e.child} ({now - e.latest_stamp:.2f} s, from {e.publisher or '?'})"


def safety_override(sub) -> str:
    """The robot's collision monitor overriding our commands now, in words ("" when it is not)."""
    st = sub.latest()
    if st is None or sub.age() > 1.5 or st.action in ("none", "disabled", "stale_cmd"):
        return ""
    why = f": {st.reason}" if st.reason else ""
    return f"robot's collision monitor: {st.action}{why} (speed x{st.ratio:.2f})"


def collision_hint(sub, now: float, within: float = 120.0) -> str:
    """The robot's last reported collision (the simulator's ``collision`` topic) if it came within ``within``
    seconds, in words."""
    c = sub.latest()
    if c is None or c.count <= 0 or not 0.0 <= now - c.header.stamp <= within:
        return ""
    return (f"collision #{c.count} at ({c.x:.2f}, {c.y:.2f}) in {c.header.frame_id or 'map'} "
            f"{now - c.header.stamp:.0f} s ago")
