"""Parameters of each costmap layer, named as the ROS costmap_2d (and nav2) parameters."""

from __future__ import annotations

from dataclasses import dataclass

from common.config import param

# keys ROS accepts inside a layer namespace that zenav reads elsewhere or does not need
LAYER_IGNORED_KEYS = ("plugin", "type", "robot_radius", "footprint", "footprint_padding", "publish_frequency",
                      "map_subscribe_transient_local", "transform_tolerance", "footprint_topic")


@dataclass(frozen=True)
class StaticLayerParams:
    enabled: bool = param(True, doc="layer contributes to the master grid")
    map_topic: str = param("map", doc="OccupancyGrid topic")
    first_map_only: bool = param(False, doc="ignore maps after the first")
    subscribe_to_updates: bool = param(False, doc="(accepted; updates arrive as whole maps)")
    track_unknown_space: bool = param(True, doc="unknown map cells stay NO_INFORMATION (else FREE)")
    use_maximum: bool = param(False, doc="combine with max instead of overwriting")
    lethal_cost_threshold: int = param(100, lo=0, hi=255, doc="occupancy at or above this is LETHAL")
    unknown_cost_value: int = param(-1, lo=-1, hi=255, doc="map value meaning unknown")
    trinary_costmap: bool = param(True, doc="free/lethal/unknown only (else scale occupancy)")


@dataclass(frozen=True)
class ObservationSourceParams:
    """One entry of ``observation_sources`` (ObservationBuffer settings)."""

    topic: str = param("", doc="topic (default: the source name)")
    sensor_frame: str = param("", doc="frame of the sensor origin (default: the message frame)")
    data_type: str = param("PointCloud", choices=("LaserScan", "PointCloud", "PointCloud2"))
    observation_persistence: float = param(0.0, lo=0.0, unit="s", doc="keep readings this long (0: latest)")
    expected_update_rate: float = param(0.0, lo=0.0, unit="s", doc="max gap between readings (0: no check)")
    min_obstacle_height: float = param(0.0, unit="m", doc="points below are dropped")
    max_obstacle_height: float = param(2.0, unit="m", doc="points above are dropped")
    obstacle_range: float = param(2.5, lo=0.0, unit="m", aliases=("obstacle_max_range",),
                                  doc="mark obstacles closer than this")
    raytrace_range: float = param(3.0, lo=0.0, unit="m", aliases=("raytrace_max_range",),
                                  doc="clear free space out to this")
    obstacle_min_range: float = param(0.0, lo=0.0, unit="m", doc="(nav2) mark only beyond this")
    raytrace_min_range: float = param(0.0, lo=0.0, unit="m", doc="(nav2) clear only beyond this")
    inf_is_valid: bool = param(False, doc="LaserScan: +inf means free out to range_max")
    marking: bool = param(True)
    clearing: bool = param(False)

    def validate(self) -> None:
        if self.min_obstacle_height > self.max_obstacle_height:
            raise ValueError(f"min_obstacle_height {self.min_obstacle_height} > max_obstacle_height "
                             f"{self.max_obstacle_height}")


# keys a source inherits from its layer / the costmap when it does not set them (ROS searchParam)
SOURCE_INHERITED_KEYS = ("obstacle_range", "raytrace_range", "min_obstacle_height", "max_obstacle_height")


@dataclass(frozen=True)
class ObstacleLayerParams:
    enabled: bool = param(True)
    observation_sources: str = param("", doc="space-separated source names")
    footprint_clearing_enabled: bool = param(True, doc="clear the cells under the robot")
    max_obstacle_height: float = param(2.0, unit="m", doc="marking ignores points above")
    combination_method: int = param(1, choices=(0, 1, 2), doc="0 overwrite, 1 maximum, 2 addition")
    track_unknown_space: bool | None = param(None, doc="default: the costmap's track_unknown_space")
    # inherited by the sources that do not set them (accepted here as ROS finds them by searchParam)
    obstacle_range: float | None = param(None, lo=0.0, unit="m")
    raytrace_range: float | None = param(None, lo=0.0, unit="m")
    min_obstacle_height: float | None = param(None, unit="m")


@dataclass(frozen=True)
class VoxelLayerParams(ObstacleLayerParams):
    origin_z: float = param(0.0, unit="m", doc="height of the bottom of the voxel grid")
    z_resolution: float = param(0.2, lo=1e-3, unit="m", doc="voxel height")
    z_voxels: int = param(10, lo=1, hi=16, doc="voxels per column (ROS packs them in 16 bits)")
    unknown_threshold: int = param(15, lo=0, hi=16, doc="cleared column with more unknown is unknown")
    mark_threshold: int = param(0, lo=0, hi=16, doc="a column with more marked voxels is lethal")
    publish_voxel_map: bool = param(False, doc="(accepted; use VoxelLayer.voxels())")


@dataclass(frozen=True)
class InflationLayerParams:
    enabled: bool = param(True)
    inflation_radius: float = param(0.55, lo=0.0, hi=50.0, unit="m", doc="how far cost spreads")
    cost_scaling_factor: float = param(10.0, lo=0.0, unit="1/m", doc="exponential decay rate")
    inflate_unknown: bool = param(False, doc="inflated cost may overwrite unknown cells")
    inflate_around_unknown: bool = param(False, doc="(nav2) unknown cells are inflation sources")
