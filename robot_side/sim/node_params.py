"""Parameters of the simulator bus node (``robot_side.sim.node``) that the pure Simulator does not have."""

from __future__ import annotations

from dataclasses import dataclass

from common.config import param

__all__ = ["SimNodeParams", "SIMULATOR_KEYS"]

# keys of the node's mapping that go to ``Simulator.from_config``; every other key is a SimNodeParams field
SIMULATOR_KEYS = ("world", "start", "world_params", "sim", "base", "laser", "depth_camera", "sonar", "engine",
                  "physics")


@dataclass(frozen=True)
class SimNodeParams:
    speed: float | None = param(None, lo=0.01, hi=1000.0, aliases=("real_time_factor",),
                                doc="sim seconds per wall second (N<1 too); default sim.real_time_factor")
    start_time: float | None = param(None, lo=0.0, unit="s",
                                     doc="sim time at start; default the wall time at start (consistent "
                                         "stamps for nodes on the wall clock at speed 1)")
    default_world: str = param("room", doc="world used when the mapping has no 'world'")
    odom_rate: float = param(50.0, lo=0.1, hi=1000.0, unit="Hz", doc="odom + tf odom->base_link (sim time)")
    ground_truth_rate: float = param(50.0, lo=0.1, hi=1000.0, unit="Hz", doc="ground_truth (sim time)")
    motor_state_rate: float = param(1.0, lo=0.01, hi=100.0, unit="Hz", doc="motor_state, also sent on change")
    battery_rate: float = param(1.0, lo=0.01, hi=100.0, unit="Hz", doc="battery_state (sim time)")
    battery_start: float = param(1.0, lo=0.0, hi=1.0, doc="charge fraction at start")
    battery_drain_per_hour: float = param(0.25, lo=0.0, hi=100.0, doc="charge fraction lost per sim hour")
    battery_empty_voltage: float = param(11.0, lo=0.0, hi=100.0, unit="V", doc="voltage at 0 %")
    battery_full_voltage: float = param(12.8, lo=0.0, hi=100.0, unit="V", doc="voltage at 100 % (12 V SLA)")
    bumper_rate: float = param(0.0, lo=0.0, hi=100.0, unit="Hz",
                               doc="bumper_state (the P3-AT's bumpers, robot_side/bumpers/geometry.py), each the "
                                   "segments pressed since the last; 0: no bumpers (a P2OS SIP cycle: 10)")
    mount_tf: bool = param(True, doc="publish base_link->laser and base_link->camera_link from the sensor "
                                     "mounts; false when a static transform node owns those edges (the "
                                     "sim then publishes camera_link->camera_depth_frame so that the chain "
                                     "ends at the pose it renders)")
    depth_frame_id: str = param("camera_depth_frame", doc="x-forward frame of the depth sensor (openni)")
    cmd_vel_topic: str = param("cmd_vel", doc="velocity commands (safety/cmd_vel behind the collision monitor)")
    max_lag: float = param(0.5, lo=0.01, hi=60.0, unit="s",
                           doc="wall seconds behind schedule before the pacer gives up catching up")

    def validate(self) -> None:
        if self.battery_full_voltage < self.battery_empty_voltage:
            raise ValueError("battery_full_voltage must be >= battery_empty_voltage")
