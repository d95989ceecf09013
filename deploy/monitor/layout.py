"""The viewer layout (Rerun blueprint), built in code: our rviz config.

Entity paths (stable; the monitor logs to these):
  world/<topic>                    spatial data in the message's own frame (rr.CoordinateFrame)
  world/odom_trail/<k>             odometry trail segments
  tf/<child_frame>                 TF edges (rr.Transform3D with parent_frame / child_frame)
  camera/<topic>                   depth images
  plots/cmd_vel/..., plots/odom/speed, plots/move_base/distance_to_goal, plots/loop_time/<node>
  plots/sensors/<costmap>/<layer>/<source>   age of each observation source's last reading (s)
  log/move_base, log/agent/<name>, log/<costmap>/sensors, log/<topic>   text events (on change)
"""

from __future__ import annotations

import rerun.blueprint as rrb

LOCAL_CONTENTS = ["/world/local_costmap/**", "/world/scan", "/world/move_base/**", "/world/odom_trail/**",
                  "/world/camera/**", "/tf/**"]


def blueprint(map_frame: str = "map", odom_frame: str = "odom") -> rrb.Blueprint:
    """Map view (target frame ``map``), local view (``odom``), depth / plots tabs, event log."""
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial3DView(name=f"Map ({map_frame} frame)", origin="/", contents=["/world/**", "/tf/**"],
                              spatial_information=rrb.SpatialInformation(target_frame=map_frame)),
            rrb.Vertical(
                rrb.Spatial3DView(name=f"Local ({odom_frame} frame)", origin="/", contents=LOCAL_CONTENTS,
                                  spatial_information=rrb.SpatialInformation(target_frame=odom_frame)),
                rrb.Tabs(rrb.TimeSeriesView(name="cmd_vel & speed", origin="/plots",
                                            contents=["/plots/cmd_vel/**", "/plots/odom/**"]),
                         rrb.TimeSeriesView(name="loop times", origin="/plots/loop_time"),
                         rrb.TimeSeriesView(name="move_base", origin="/plots/move_base"),
                         rrb.TimeSeriesView(name="sensor age", origin="/plots/sensors"),
                         rrb.Spatial2DView(name="Depth", origin="/camera")),
                rrb.TextLogView(name="Events", origin="/log"),
                row_shares=[3, 2, 2]),
            column_shares=[3, 2]),
        collapse_panels=True)
