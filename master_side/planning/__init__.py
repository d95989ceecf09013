"""Global (navfn) and local (DWA, trajectory rollout) planners: pure algorithms over costmap grids."""
