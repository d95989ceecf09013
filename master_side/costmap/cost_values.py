"""Cost values shared by every costmap, planner and controller (the ROS costmap_2d values)."""

from __future__ import annotations

FREE = 0  # costmap_2d::FREE_SPACE
INSCRIBED = 253  # costmap_2d::INSCRIBED_INFLATED_OBSTACLE: robot centre here => footprint in collision
LETHAL = 254  # costmap_2d::LETHAL_OBSTACLE: an obstacle in this cell
NO_INFORMATION = 255  # costmap_2d::NO_INFORMATION: unknown

FREE_SPACE = FREE
INSCRIBED_INFLATED_OBSTACLE = INSCRIBED
LETHAL_OBSTACLE = LETHAL
