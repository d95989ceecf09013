"""Costmap parameters (ROS costmap_2d names) and the loader for the ROS YAML files, unchanged.

Two styles, as costmap_2d accepts them:
- pre-Hydro flat: ``costmap_common_params.yaml`` + ``global_costmap_params.yaml`` (keys under
  ``global_costmap:``); without ``plugins`` the layers are implied as ROS does: ``static_layer``
  (if static_map), ``obstacle_layer`` (VoxelLayer if map_type is voxel) and ``inflation_layer``, and the
  flat keys move into them.
- layered: a ``plugins`` list ([{name, type}] as ROS 1, or names with ``<name>.plugin`` as nav2), each
  layer's parameters under its name.
A source's obstacle_range / raytrace_range / min_ and max_obstacle_height fall back to its layer, then
the costmap level (ROS finds the ranges with searchParam; zenav does the same for the heights).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from common.config import ConfigError, load_params, param, read_yaml, strip_frame
from master_side.costmap.footprint import footprint_from_params
from master_side.costmap.layer_params import (
    LAYER_IGNORED_KEYS,
    SOURCE_INHERITED_KEYS,
    InflationLayerParams,
    ObservationSourceParams,
    ObstacleLayerParams,
    StaticLayerParams,
    VoxelLayerParams,
)
from master_side.costmap.layered import layer_class
from master_side.costmap.obstacle_layer import ObstacleLayer

__all__ = ["CostmapParams", "CostmapConfig", "LayerSpec", "load_costmap_config", "load_costmap_files",
           "StaticLayerParams", "ObstacleLayerParams", "VoxelLayerParams", "InflationLayerParams",
           "ObservationSourceParams", "KNOWN_IGNORED_KEYS"]


@dataclass(frozen=True)
class CostmapParams:
    global_frame: str = param("map", doc="frame the costmap lives in")
    robot_base_frame: str = param("base_link")
    update_frequency: float = param(5.0, lo=0.0, hi=1000.0, unit="Hz", doc="map update rate")
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
    footprint: Any = param("[]", doc="[[x, y], ...] (list or string); wins over robot_radius")
    robot_radius: float = param(0.46, lo=0.0, unit="m")
    footprint_padding: float = param(0.01, lo=-1.0, hi=10.0, unit="m")
    plugins: Any = param(None, doc="layered style: [{name, type}, ...]")

    def __post_init__(self):
        object.__setattr__(self, "global_frame", strip_frame(self.global_frame))
        object.__setattr__(self, "robot_base_frame", strip_frame(self.robot_base_frame))

    def validate(self) -> None:
        if self.width < self.resolution or self.height < self.resolution:
            raise ValueError(f"width x height {self.width} x {self.height} m is smaller than one cell "
                             f"({self.resolution} m)")


# real costmap_2d / nav2 costmap-level keys that zenav accepts and does not use
KNOWN_IGNORED_KEYS = ("always_send_full_costmap", "footprint_topic", "use_sim_time", "clearable_layers",
                      "filters", "initial_transform_timeout", "introspection_mode", "map_vis_z",
                      "robot_radius_topic", "subscribe_to_stamped_footprint")
_STATIC_KEYS = ("map_topic", "unknown_cost_value", "lethal_cost_threshold", "trinary_costmap", "use_maximum",
                "first_map_only", "subscribe_to_updates")
_OBSTACLE_KEYS = ("max_obstacle_height", "min_obstacle_height", "obstacle_range", "raytrace_range",
                  "observation_sources", "footprint_clearing_enabled", "combination_method")
_VOXEL_KEYS = ("origin_z", "z_resolution", "z_voxels", "mark_threshold", "unknown_threshold",
               "publish_voxel_map")
_INFLATION_KEYS = ("inflation_radius", "cost_scaling_factor", "inflate_unknown", "inflate_around_unknown")
_FLAT_LAYER_KEYS = _STATIC_KEYS + _OBSTACLE_KEYS + _VOXEL_KEYS + _INFLATION_KEYS


@dataclass(frozen=True)
class LayerSpec:
    name: str
    type: str  # plugin type name, e.g. "costmap_2d::InflationLayer"
    params: Any
    sources: tuple[tuple[str, ObservationSourceParams], ...] | None = None  # obstacle / voxel layers


@dataclass(frozen=True)
class CostmapConfig:
    name: str  # "global_costmap" / "local_costmap"
    costmap: CostmapParams
    layers: tuple[LayerSpec, ...]
    footprint: tuple[tuple[float, float], ...]  # padded polygon, robot frame
    style: str  # "flat" (pre-Hydro) or "layered"
    ignored: tuple[str, ...] = ()  # accepted keys that have no effect here

    @property
    def size_in_cells(self) -> tuple[int, int]:
        c = self.costmap
        return int(c.width / c.resolution + 1e-6), int(c.height / c.resolution + 1e-6)


class _Origins:
    """Which file each key path came from, so errors name the right file."""

    def __init__(self, default: str):
        self.default = default
        self.by_path: dict[tuple[str, ...], str] = {}
        self.moved: dict[tuple[str, str], tuple[str, ...]] = {}  # (layer, key) -> path in the file
        self.wrapper: dict[str, str] = {}  # file -> its top-level key (global_costmap / local_costmap)

    def as_written(self, key: str) -> tuple[str, ...]:
        """A key path as the user wrote it (pre-Hydro keys were moved into implied layers)."""
        parts = tuple(key.split("."))
        return self.moved.get(parts[:2], parts[:2]) + parts[2:] if len(parts) >= 2 else parts

    def file_of(self, key: str) -> str:
        parts = tuple(p.split("[")[0] for p in self.as_written(key))
        for n in range(len(parts), 0, -1):
            if parts[:n] in self.by_path:
                return self.by_path[parts[:n]]
        return self.default

    def load(self, cls: type, mapping: dict, section: str, ignore: tuple[str, ...] = ()) -> Any:
        try:
            return load_params(cls, mapping, source=self.file_of(section), section=section, ignore=ignore)
        except ConfigError as e:
            raise self.error(e.key, str(e).split(": ", 2)[-1]) from None

    def error(self, key: str, message: str) -> ConfigError:
        file = self.file_of(key)
        path = (self.wrapper[file],) if file in self.wrapper else ()
        return ConfigError(file, ".".join(path + self.as_written(key)), message)


def _merge(base: dict, top: dict, src: str, origins: _Origins, path: tuple[str, ...] = ()) -> dict:
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


def _record(d: dict, src: str, origins: _Origins, path: tuple[str, ...]) -> None:
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


def load_costmap_config(common: dict | None, specific: dict | None,
                        source: str | tuple[str, str] = "<config>", *,
                        name: str | None = None) -> CostmapConfig:
    """Costmap configuration from the common and the specific mapping (e.g. read from the ROS YAML files).

    ``source`` names the file(s) for errors: one string, or (common_file, specific_file). ``name`` defaults
    to the specific file's top-level key, else local_costmap for a rolling window, else global_costmap.
    """
    src_common, src_specific = (source, source) if isinstance(source, str) else source
    spec_map, spec_name = _unwrap(specific, name)
    common_map, _ = _unwrap(common, name or spec_name)
    origins = _Origins(src_specific)
    if spec_name and src_specific != src_common:
        origins.wrapper[src_specific] = spec_name
    merged = _merge(_merge({}, common_map, src_common, origins), spec_map, src_specific, origins)
    flat = merged.get("plugins") is None
    layers_raw, ignored = _flat_layers(merged, origins) if flat else _plugin_layers(merged, origins)
    layer_keys = tuple(n for n, _t, _m in layers_raw)
    accepted = set(KNOWN_IGNORED_KEYS) | set(_FLAT_LAYER_KEYS) | set(layer_keys)
    accepted |= {k for k, v in merged.items() if isinstance(v, dict)}  # layer / source namespaces
    costmap = origins.load(CostmapParams, merged, "", ignore=tuple(accepted))
    try:
        fp = footprint_from_params(costmap.footprint, costmap.robot_radius, costmap.footprint_padding)
    except ValueError as e:
        raise origins.error("footprint", str(e)) from None
    specs = tuple(_layer_spec(n, t, m, merged, origins) for n, t, m in layers_raw)
    if not flat:
        used = set(layer_keys) | set(CostmapParams.__dataclass_fields__) | set(KNOWN_IGNORED_KEYS)
        ignored += tuple(sorted(k for k in merged if k not in used and k not in SOURCE_INHERITED_KEYS))
        ignored += tuple(k for k in ("static_map", "map_type") if k in merged)  # pre-Hydro only
    final_name = name or spec_name or ("local_costmap" if costmap.rolling_window else "global_costmap")
    return CostmapConfig(final_name, costmap, specs, tuple(map(tuple, fp.tolist())),
                         "flat" if flat else "layered", ignored)


def load_costmap_files(common_path: str | Path, specific_path: str | Path, *, name: str | None = None
                       ) -> CostmapConfig:
    return load_costmap_config(read_yaml(common_path), read_yaml(specific_path),
                               (str(common_path), str(specific_path)), name=name)


def _flat_layers(m: dict, origins: _Origins) -> tuple[list[tuple[str, str, dict]], tuple[str, ...]]:
    """The layers costmap_2d derives from pre-Hydro parameters (Costmap2DROS::resetOldParameters)."""
    layers, ignored = [], []
    for layer in ("static_layer", "obstacle_layer", "inflation_layer"):
        for k in (*_FLAT_LAYER_KEYS, "track_unknown_space", *str(m.get("observation_sources", "")).split()):
            if k in m:
                origins.moved[(layer, k)] = (k,)
    if m.get("static_map") is True:
        d = dict(m.get("static_layer") or {})
        d.update({k: m[k] for k in _STATIC_KEYS + ("track_unknown_space",) if k in m})
        layers.append(("static_layer", "costmap_2d::StaticLayer", d))
    voxel = m.get("map_type") == "voxel"
    d = dict(m.get("obstacle_layer") or {})
    moved = _OBSTACLE_KEYS + ("track_unknown_space",) + (_VOXEL_KEYS if voxel else ())
    d.update({k: m[k] for k in moved if k in m})
    for src in str(m.get("observation_sources", "")).split():
        if src in m:
            d[src] = m[src]
    ignored += [k for k in _VOXEL_KEYS if k in m and not voxel]
    layers.append(("obstacle_layer", "costmap_2d::VoxelLayer" if voxel else "costmap_2d::ObstacleLayer", d))
    d = dict(m.get("inflation_layer") or {})
    d.update({k: m[k] for k in _INFLATION_KEYS if k in m})
    layers.append(("inflation_layer", "costmap_2d::InflationLayer", d))
    if m.get("static_map") is not True:
        ignored += [k for k in _STATIC_KEYS if k in m]
    return layers, tuple(ignored)


def _plugin_layers(m: dict, origins: _Origins) -> tuple[list[tuple[str, str, dict]], tuple[str, ...]]:
    plugins = m["plugins"]
    if not isinstance(plugins, list):
        raise origins.error("plugins", f"expected a list of {{name, type}}, got {plugins!r}")
    out, seen = [], set()
    for i, p in enumerate(plugins):
        if isinstance(p, dict) and set(p) <= {"name", "type", "enabled"} and "name" in p and "type" in p:
            name, kind = str(p["name"]), str(p["type"])
        elif isinstance(p, str) and isinstance(m.get(p), dict) and "plugin" in m[p]:
            name, kind = p, str(m[p]["plugin"])  # nav2: plugins: [name, ...], name.plugin: type
        else:
            raise origins.error(f"plugins[{i}]", f"expected {{name: ..., type: ...}}, got {p!r}")
        if name in seen:
            raise origins.error(f"plugins[{i}]", f"layer name {name!r} used twice")
        seen.add(name)
        try:
            layer_class(kind)
        except KeyError as e:
            raise origins.error(f"plugins[{i}].type", str(e.args[0])) from None
        raw = m.get(name, {})
        if not isinstance(raw, dict):
            raise origins.error(name, f"layer parameters must be a mapping, got {raw!r}")
        out.append((name, kind, raw))
    return out, ()


def _layer_spec(name: str, kind: str, raw: dict, top: dict, origins: _Origins) -> LayerSpec:
    cls = layer_class(kind)
    if not issubclass(cls, ObstacleLayer):
        return LayerSpec(name, kind, origins.load(cls.Params, raw, name, ignore=LAYER_IGNORED_KEYS))
    names = str(raw.get("observation_sources", "")).split()
    params = origins.load(cls.Params, raw, name, ignore=LAYER_IGNORED_KEYS + tuple(names))
    sources = []
    for s in names:
        src = raw.get(s, {})
        if not isinstance(src, dict):
            raise origins.error(f"{name}.{s}", f"observation source must be a mapping, got {src!r}")
        src = dict(src)
        for k in SOURCE_INHERITED_KEYS:
            if k not in src and raw.get(k) is not None:
                src[k] = raw[k]
            elif k not in src and k in top:
                src[k] = top[k]
        sp = origins.load(ObservationSourceParams, src, f"{name}.{s}")
        sp = dataclasses.replace(sp, topic=sp.topic or s, sensor_frame=strip_frame(sp.sensor_frame))
        sources.append((s, sp))
    return LayerSpec(name, kind, params, tuple(sources))
