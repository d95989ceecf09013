"""hector_mapping-style SLAM without odometry: multi-resolution log-odds grids, Gauss-Newton scan matching."""
