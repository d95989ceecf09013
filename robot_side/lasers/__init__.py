"""Planar laser drivers: Hokuyo (SCIP 2.0) and SICK S300; each publishes LaserScan as the simulator does."""
