"""Depth camera conversions: depth image -> LaserScan / point cloud, virtual scans, scan merging."""
