"""What zenav's SLAM configuration for the P3-AT (``p3at_slam_zenav.yaml``) changes for the sensor it carries.

The master file serves both of the P3-AT's simulated sensor sets: the tutorial's Kinect (57 deg ahead,
``robot_side/config/p3at_sim.yaml``) and a 180 deg planar laser (``p3at_sim_laser.yaml``). With the laser,
move_base's escape may also turn and then drive (``p3at_zenav/move_base_laser.yaml`` says why); with the
Kinect it may not, as the turn sweeps walls beside the body that the camera has not shown. ``zenav demo
--explore`` and ``bench/explore.py`` pass these as ``zenav master --set`` values, as a user does by hand.
"""

from __future__ import annotations

from pathlib import Path

CONFIG = Path(__file__).resolve().parents[2] / "master_side" / "config"
LASER_MOVE_BASE = CONFIG / "p3at_zenav" / "move_base_laser.yaml"

_SLAM = {"laser": (f"move_base.move_base={LASER_MOVE_BASE}",)}


def slam_sensor_sets(sensor: str) -> tuple[str, ...]:
    """``zenav master --set`` values for p3at_slam_zenav.yaml with the P3-AT's ``sensor`` (laser, kinect)."""
    if sensor not in ("laser", "kinect"):
        raise ValueError(f"sensor {sensor!r}: laser or kinect")
    return _SLAM.get(sensor, ())
