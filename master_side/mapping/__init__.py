"""Occupancy map files (ROS map_server format) and the map server / saver nodes."""
