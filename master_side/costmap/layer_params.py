"""Parameters of the costmap and of each layer, named as the ROS costmap_2d (and nav2) parameters; the
tables of which costmap-level keys go into which layer; and where each key of the two costmap files came
from (``merge_files``, ``Origins``), so problems name the file and the key as the user wrote them."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from common.config import param, strip_frame
from master_side.ros_params import INFLATION_LAYER, OBSTACLE_LAYER, STATIC_LAYER, VOXEL_LAYER


@dataclass(frozen=True)
class StaticLayerParams:
    enabled: bool = param(True, doc="layer contributes to the master grid")
    map_topic: str = param("map", doc="OccupancyGrid topic")
    first_map_only: bool = param(False, doc="ignore maps after the first")
    subscribe_to_updates: bool = param(False, no_effect=True,
                                       doc="accepted; zenav always receives whole maps")
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
    min_mark_separation: float = param(0.0, lo=0.0, hi=5.0, unit="m",
                                       doc="(zenav) mark a point only where no obstacle is marked in the layer "
                                           "within this distance along x and y (a square window; marks under "
                                           "the footprint do not count; 0: always), unless every mark there "
                                           "lies farther from the sensor than the point's cell by more than a "
                                           "cell (centre to centre): an imprecise sensor (a sonar's echo may be "
                                           "anywhere across its cone) then adds only what the other sources "
                                           "have not seen, or saw farther than it is now, not a second, "
                                           "displaced wall")
    min_mark_separation_fov: float = param(0.0, lo=0.0, hi=math.pi, unit="rad",
                                           doc="(zenav) with min_mark_separation: only marks within the "
                                               "sensor's cone of this width about the line from the sensor to "
                                               "the point count (a sonar: 15 deg, 0.26 rad); 0: the whole "
                                               "square window")
    footprint_clearing: bool = param(True, doc="(zenav) false: this source's marks are freed under the robot's "
                                                 "own outline only, not under the padded footprint (a near-field "
                                                 "sensor, a sonar, hearing a wall within the padding beside the body)")
    marking: bool = param(True)
    clearing: bool = param(False)

    def validate(self) -> None:
        if self.min_obstacle_height > self.max_obstacle_height:
            raise ValueError(f"min_obstacle_height {self.min_obstacle_height} > max_obstacle_height "
                             f"{self.max_obstacle_height}")
        if self.min_mark_separation_fov > 0 and self.min_mark_separation <= 0:
            raise ValueError("min_mark_separation_fov needs min_mark_separation > 0 (it narrows that window)")


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
    publish_voxel_map: bool = param(False, no_effect=True,
                                    doc="accepted; not published (VoxelLayer.voxels() in code)")


@dataclass(frozen=True)
class InflationLayerParams:
    enabled: bool = param(True)
    inflation_radius: float = param(0.55, lo=0.0, hi=50.0, unit="m", doc="how far cost spreads")
    cost_scaling_factor: float = param(10.0, lo=0.0, unit="1/m", doc="exponential decay rate")
    inflate_unknown: bool = param(False, doc="inflated cost may overwrite unknown cells")
    inflate_around_unknown: bool = param(False, doc="(nav2) unknown cells are inflation sources")


@dataclass(frozen=True)
class CostmapParams:
    global_frame: str = param("map", doc="frame the costmap lives in")
    robot_base_frame: str = param("base_link")
    update_frequency: float = param(5.0, lo=0.0, hi=1000.0, unit="Hz", doc="map update rate")
    update_on_observation: bool = param(
        False, doc="zenav: update as soon as an observation arrives (at most update_frequency times a "
                   "second; without observations every max(2/update_frequency, 0.5) s); false = ROS's fixed-rate loop")
    publish_frequency: float = param(0.0, lo=0.0, hi=1000.0, unit="Hz", doc="display rate (0: never)")
    transform_tolerance: float = param(0.3, lo=0.0, unit="s", doc="max TF age")
    static_map: bool = param(False, doc="pre-Hydro: add a static layer")
    rolling_window: bool = param(False, doc="window centred on the robot")
    width: float = param(10.0, lo=0.0, hi=1e4, unit="m")
    height: float = param(10.0, lo=0.0, hi=1e4, unit="m")
    resolution: float = param(0.05, lo=1e-4, hi=100.0, unit="m")
    origin_x: float = param(0.0, unit="m")
    origin_y: float = param(0.0, unit="m")
    map_type: str = param("costmap", choices=("costmap", "voxel"), doc="pre-Hydro: voxel -> VoxelLayer")
    track_unknown_space: bool = param(False, doc="master starts NO_INFORMATION (else FREE)")
    unseen_cost: int = param(-1, lo=-1, hi=252, doc="zenav: with track_unknown_space, the costmap topic carries "
                             "cells no sensor has seen at this cost instead of NO_INFORMATION (a local planner "
                             "then prefers seen cells without refusing unseen ones); -1: NO_INFORMATION, as ROS")
    footprint: Any = param("[]", doc="[[x, y], ...] (list or string); wins over robot_radius")
    robot_radius: float = param(0.46, lo=0.0, unit="m")
    footprint_padding: float = param(0.01, lo=-1.0, hi=10.0, unit="m")
    plugins: Any = param(None, doc="layered style: [{name, type}, ...]")

    @property
    def unseen_as(self) -> int | None:
        """The cost unseen cells go out at on the costmap topic (None: NO_INFORMATION)."""
        return self.unseen_cost if self.unseen_cost >= 0 and self.track_unknown_space else None

    def __post_init__(self):
        object.__setattr__(self, "global_frame", strip_frame(self.global_frame))
        object.__setattr__(self, "robot_base_frame", strip_frame(self.robot_base_frame))

    def validate(self) -> None:
        if self.unseen_cost >= 0 and not self.track_unknown_space:
            raise ValueError("unseen_cost needs track_unknown_space: true (without it no cell is unseen)")
        if self.width < self.resolution or self.height < self.resolution:
            raise ValueError(f"width x height {self.width} x {self.height} m is smaller than one cell "
                             f"({self.resolution} m)")


# pre-Hydro flat keys, by the implied layer they move into (zenav moves a few more than ROS)
STATIC_KEYS = ("map_topic", "unknown_cost_value", "lethal_cost_threshold", "trinary_costmap", "use_maximum",
               "first_map_only", "subscribe_to_updates")
OBSTACLE_KEYS = ("max_obstacle_height", "min_obstacle_height", "obstacle_range", "raytrace_range",
                 "observation_sources", "footprint_clearing_enabled", "combination_method")
VOXEL_KEYS = ("origin_z", "z_resolution", "z_voxels", "mark_threshold", "unknown_threshold", "publish_voxel_map")
INFLATION_KEYS = ("inflation_radius", "cost_scaling_factor", "inflate_unknown", "inflate_around_unknown")
FLAT_LAYER_KEYS = STATIC_KEYS + OBSTACLE_KEYS + VOXEL_KEYS + INFLATION_KEYS
# layered style: costmap-level keys Costmap2DROS copies into each layer of a type (copyParentParameters)
PARENT_KEYS = {
    STATIC_LAYER: ("map_topic", "unknown_cost_value", "lethal_cost_threshold", "track_unknown_space"),
    VOXEL_LAYER: VOXEL_KEYS,
    OBSTACLE_LAYER: ("max_obstacle_height", "raytrace_range", "obstacle_range", "track_unknown_space"),
    INFLATION_LAYER: ("cost_scaling_factor", "inflation_radius"),
}


# -- the two costmap files -------------------------------------------------------------------------------
class Origins:
    """Which file each key path came from, and where keys moved (pre-Hydro keys into implied layers,
    costmap-level keys copied into layers, inherited source keys), so problems name what the user wrote."""

    def __init__(self, default: str):
        self.default = default
        self.by_path: dict[tuple[str, ...], str] = {}
        self.moved: dict[tuple[str, ...], tuple[str, ...]] = {}  # path as loaded -> path in the file
        self.wrapper: dict[str, str] = {}  # file -> its top-level key (global_costmap / local_costmap)

    def as_written(self, key: str) -> tuple[str, ...]:
        """A key path as the user wrote it (following moves to shorter paths)."""
        parts = tuple(key.split(".")) if key else ()
        for n in range(len(parts), 1, -1):
            if parts[:n] in self.moved:
                return self.as_written(".".join(self.moved[parts[:n]] + parts[n:]))
        return parts

    def file_of(self, key: str) -> str:
        parts = tuple(p.split("[")[0] for p in self.as_written(key))
        for n in range(len(parts), 0, -1):
            if parts[:n] in self.by_path:
                return self.by_path[parts[:n]]
        return self.default

    def error(self, key: str, message: str) -> tuple[str, str, str]:
        """(file, key as shown, message) for a key path of the merged costmap namespace."""
        file = self.file_of(key)
        path = (self.wrapper[file],) if file in self.wrapper else ()
        return file, ".".join(path + self.as_written(key)), message


def _merge(base: dict, top: dict, src: str, origins: Origins, path: tuple[str, ...] = ()) -> dict:
    out = dict(base)
    for k, v in top.items():
        key = (*path, str(k))
        origins.by_path[key] = src
        if isinstance(v, dict) and isinstance(out.get(k), dict):
            out[k] = _merge(out[k], v, src, origins, key)
        else:
            out[k] = v
            if isinstance(v, dict):
                _record(v, src, origins, key)
    return out


def _record(d: dict, src: str, origins: Origins, path: tuple[str, ...]) -> None:
    for k, v in d.items():
        origins.by_path[(*path, str(k))] = src
        if isinstance(v, dict):
            _record(v, src, origins, (*path, str(k)))


def _unwrap(mapping: dict | None, name: str | None) -> tuple[dict, str | None]:
    m = dict(mapping or {})
    keys = [k for k in ("global_costmap", "local_costmap") if isinstance(m.get(k), dict)]
    if len(m) == 1 and len(keys) == 1 and (name is None or name == keys[0]):
        return dict(m[keys[0]]), keys[0]
    return m, None


def merge_files(common: dict | None, specific: dict | None, source: str | tuple[str, str],
                name: str | None) -> tuple[dict, Origins, str | None]:
    """The costmap namespace as ROS builds it from the common file then the specific one (which wins),
    the origins of its keys and the specific file's top-level key (global_costmap / local_costmap)."""
    src_common, src_specific = (source, source) if isinstance(source, str) else source
    spec_map, spec_name = _unwrap(specific, name)
    common_map, _ = _unwrap(common, name or spec_name)
    origins = Origins(src_specific)
    if spec_name and src_specific != src_common:
        origins.wrapper[src_specific] = spec_name
    merged = _merge(_merge({}, common_map, src_common, origins), spec_map, src_specific, origins)
    return merged, origins, spec_name
