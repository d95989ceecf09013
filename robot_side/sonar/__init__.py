"""A Pioneer's sonar ring: its geometry, and the points that put its echoes in a costmap."""
