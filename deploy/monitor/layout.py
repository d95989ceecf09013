"""The viewer layout (Rerun blueprint), built in code: our rviz config. The same blueprint is sent to the
native viewer, the web viewer of ``--serve-web`` and saved recordings.

Entity paths (stable; the monitor logs to these):
  world/<topic>                    spatial data in the message's own frame (rr.CoordinateFrame)
  world/robot                      a marker at the robot's base frame: the map views follow it
  world/particlecloud(/covariance) AMCL's particles and their 2-sigma ellipse
  world/odom_trail/<k>             odometry trail segments
  tf/<child_frame>                 TF edges (rr.Transform3D with parent_frame / child_frame)
  camera/<topic>                   depth images
  plots/cmd_vel/..., plots/odom/speed, plots/move_base/distance_to_goal, plots/loop_time/<node>
  plots/sensors/<costmap>/<layer>/<source>   age of each observation source's last reading (s)
  log/move_base, log/agent/<name>, log/<costmap>/sensors, log/<topic>   text events (on change)

The map and local views are 3D views looked at from straight above (as rviz's top-down view): Rerun's
2D views cannot show 3D data such as the grid maps and TF-placed scans.
"""

from __future__ import annotations

import rerun.blueprint as rrb

LOCAL_CONTENTS = ["/world/local_costmap/**", "/world/scan", "/world/move_base/**", "/world/odom_trail/**",
                  "/world/camera/**", "/world/robot", "/world/**/footprint", "/tf/**"]
ROBOT_ENTITY = "/world/robot"
LOCAL_HEIGHT = 6.0
# Eye height (m) above the ground before the map is known; then ``fit_height`` of the map.
DEFAULT_HEIGHT = 12.0
# The 3D view's field of view seen from above: the ground visible down the view is ~1.1 x the eye height
# (measured in the 0.41 web viewer), across it the view's width / height times that.
SPAN_Y = 1.1
# The narrowest map view to fit: in our web page the viewer has 56 % of the window and the map view 3/5 of
# that above the time panel, about 540 x 620 px at 1600 x 900 (a 3:2 fit there showed a quarter of the room,
# issue 31); the native viewer's map view is wider, where the map then has a margin.
MIN_ASPECT = 0.85


def fit_height(width_m: float, height_m: float, aspect: float = MIN_ASPECT) -> float:
    """Eye height at which a ``width_m`` x ``height_m`` map just fits a view ``aspect`` (width / height)."""
    return 1.05 * max(width_m / (SPAN_Y * aspect), height_m / SPAN_Y, 1.0)


def top_down(centre: tuple[float, float], height: float, follow: bool) -> rrb.EyeControls3D:
    """A camera straight above ``centre`` looking down, +y toward the top of the screen. ``follow``
    asks Rerun to track the robot marker (experimental: in the 0.41 web viewer the tracked eye moves onto
    the marker itself, so it is off by default)."""
    cx, cy = centre
    return rrb.EyeControls3D(kind=rrb.Eye3DKind.FirstPerson, position=[cx, cy, height],
                             look_target=[cx, cy, 0.0], eye_up=[0.0, 1.0, 0.0],
                             tracking_entity=ROBOT_ENTITY if follow else None)


def blueprint(map_frame: str = "map", odom_frame: str = "odom", follow: bool = False,
              centre: tuple[float, float] = (0.0, 0.0), height: float = DEFAULT_HEIGHT) -> rrb.Blueprint:
    """Map view (target frame ``map``, top-down over ``centre`` from ``height``; the monitor sends it
    again fitted to the map once the map arrives), local view (``odom``, top-down over the odom origin),
    depth / plots tabs, event log."""
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial3DView(name=f"Map ({map_frame} frame)", origin="/", contents=["/world/**", "/tf/**"],
                              spatial_information=rrb.SpatialInformation(target_frame=map_frame),
                              eye_controls=top_down(centre, height, follow),
                              line_grid=False),
            rrb.Vertical(
                rrb.Spatial3DView(name=f"Local ({odom_frame} frame)", origin="/", contents=LOCAL_CONTENTS,
                                  spatial_information=rrb.SpatialInformation(target_frame=odom_frame),
                                  eye_controls=top_down((0.0, 0.0), LOCAL_HEIGHT, follow),
                                  line_grid=False),
                rrb.Tabs(rrb.TimeSeriesView(name="cmd_vel & speed", origin="/plots",
                                            contents=["/plots/cmd_vel/**", "/plots/odom/**"]),
                         rrb.TimeSeriesView(name="loop times", origin="/plots/loop_time"),
                         rrb.TimeSeriesView(name="move_base", origin="/plots/move_base"),
                         rrb.TimeSeriesView(name="sensor age", origin="/plots/sensors"),
                         rrb.Spatial2DView(name="Depth", origin="/camera")),
                rrb.TextLogView(name="Events", origin="/log"),
                row_shares=[3, 2, 2]),
            column_shares=[3, 2]),
        live_time_panel(),
        collapse_panels=True)


def live_time_panel() -> rrb.TimePanel:
    """The time cursor follows the newest data. Without it a viewer that connects to a running monitor
    (the page's, opened after the start) played the history at 1x from its beginning and stayed that far
    behind the robot for good: a minute late on a page opened a minute in (bench/monitor_live.py, issue 31)."""
    return rrb.TimePanel(play_state="following")
