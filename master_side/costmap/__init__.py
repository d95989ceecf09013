"""Layered costmaps with ROS costmap_2d semantics and parameter names.

Build one from the ROS YAML files::

    from master_side.costmap import load_costmap_files, LayeredCostmap
    cfg = load_costmap_files("costmap_common_params.yaml", "local_costmap_params.yaml")
    lcm = LayeredCostmap.from_config(cfg)
    lcm.layer("obstacle_layer").add_observation("laser_scan_sensor", points_xyz, origin_xyz, stamp)
    window = lcm.update_map(robot_pose)          # Pose2D in cfg.costmap.global_frame
    lcm.master.data                              # uint8 [row=y, col=x]
"""

from master_side.costmap.cost_values import FREE, INSCRIBED, LETHAL, NO_INFORMATION
from master_side.costmap.costmap2d import Costmap2D, Window
from master_side.costmap.layer import Bounds, Layer
from master_side.costmap.layered import LayeredCostmap, layer_class, register_layer
from master_side.costmap.params import CostmapConfig, load_costmap_config, load_costmap_files

__all__ = [
    "FREE", "INSCRIBED", "LETHAL", "NO_INFORMATION", "Costmap2D", "Window", "Bounds", "Layer",
    "LayeredCostmap", "layer_class", "register_layer", "CostmapConfig", "load_costmap_config",
    "load_costmap_files",
]
