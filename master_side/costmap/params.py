"""Costmap parameters (ROS costmap_2d names) and the loader for the ROS YAML files, unchanged.

Two styles, as costmap_2d accepts them:
- pre-Hydro flat: ``costmap_common_params.yaml`` + ``global_costmap_params.yaml`` (keys under
  ``global_costmap:``); without ``plugins`` the layers are implied as ROS does: ``static_layer``
  (if static_map), ``obstacle_layer`` (VoxelLayer if map_type is voxel) and ``inflation_layer``, and the
  flat keys move into them.
- layered: a ``plugins`` list ([{name, type}] as ROS 1, or names with ``<name>.plugin`` as nav2), each
  layer's parameters under its name; as Costmap2DROS does, a costmap-level ``inflation_radius``,
  ``z_voxels``, ``obstacle_range``, ... is copied into every layer of the type that reads it (and wins).
A source's obstacle_range / raytrace_range / min_ and max_obstacle_height fall back to its layer, then
the costmap level (ROS finds the ranges with searchParam; zenav does the same for the heights).

Every problem of both files is reported in one ConfigError. ROS parameters that have no effect here
(not implemented by zenav, another component's, pre-Hydro keys beside ``plugins``) are accepted and
listed in ``CostmapConfig.notes`` (catalogue: ``master_side.ros_params``). The sorting of one namespace
into layers and sources is ``master_side.costmap.params_loader``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from common.config import ConfigError, Problems, load_params, param, read_yaml
from master_side.costmap.footprint import footprint_from_params
from master_side.costmap.layer_params import (
    CostmapParams,
    InflationLayerParams,
    ObservationSourceParams,
    ObstacleLayerParams,
    StaticLayerParams,
    VoxelLayerParams,
    merge_files,
)
from master_side.costmap.params_loader import LayerSpec, NamespaceLoader

__all__ = ["CostmapParams", "CostmapConfig", "LayerSpec", "load_costmap_config", "load_costmap_files",
           "check_costmap_node", "StaticLayerParams", "ObstacleLayerParams", "VoxelLayerParams",
           "InflationLayerParams", "ObservationSourceParams"]


@dataclass(frozen=True)
class CostmapConfig:
    name: str  # "global_costmap" / "local_costmap"
    costmap: CostmapParams
    layers: tuple[LayerSpec, ...]
    footprint: tuple[tuple[float, float], ...]  # padded polygon, robot frame
    style: str  # "flat" (pre-Hydro) or "layered"
    ignored: tuple[str, ...] = ()  # keys (as written in the costmap namespace) accepted without effect
    notes: tuple[str, ...] = ()    # the same as "file: key: no effect (why)" lines


def load_costmap_config(common: dict | None, specific: dict | None,
                        source: str | tuple[str, str] = "<config>", *, name: str | None = None,
                        notes: list[str] | None = None) -> CostmapConfig:
    """Costmap configuration from the common and the specific mapping (e.g. read from the ROS YAML files).

    ``source`` names the file(s) for errors: one string, or (common_file, specific_file). ``name`` defaults
    to the specific file's top-level key, else local_costmap for a rolling window, else global_costmap.
    Raises one ConfigError with every problem of both; ``notes`` (if given) gets the no-effect notes.
    """
    merged, origins, spec_name = merge_files(common, specific, source, name)
    ld = NamespaceLoader(merged, origins)
    flat = merged.get("plugins") is None
    layers_raw = ld.flat_layers() if flat else ld.plugin_layers()
    costmap = ld.costmap_level(flat, layers_raw)
    fp = None
    if costmap is not None:
        try:
            fp = footprint_from_params(costmap.footprint, costmap.robot_radius, costmap.footprint_padding)
        except ValueError as e:
            ld.problems.add(*origins.error("footprint", str(e)))
    specs = tuple(ld.layer_spec(n, t, m) for n, t, m in layers_raw)
    if ld.problems:
        raise ConfigError.of(list(dict.fromkeys(ld.problems.items)))
    final_name = name or spec_name or ("local_costmap" if costmap.rolling_window else "global_costmap")
    if notes is not None:
        notes.extend(ld.notes)
    return CostmapConfig(final_name, costmap, specs, tuple(map(tuple, fp.tolist())),
                         "flat" if flat else "layered", tuple(ld.ignored), tuple(ld.notes))


def load_costmap_files(common_path: str | Path, specific_path: str | Path, *, name: str | None = None,
                       notes: list[str] | None = None) -> CostmapConfig:
    problems = Problems()
    data: list[dict | None] = []
    for path in (common_path, specific_path):
        with problems.collect():
            data.append(read_yaml(path))
    problems.raise_if_any()
    return load_costmap_config(data[0], data[1], (str(common_path), str(specific_path)), name=name, notes=notes)


@dataclass(frozen=True)
class CostmapNodeParams:
    """The costmap node's own mapping (``master_side.costmap.node``)."""

    common: str = param("", doc="costmap_common_params.yaml (relative to this file)")
    specific: str = param("", doc="global_costmap_params.yaml / local_costmap_params.yaml")
    name: str | None = param(None, doc="global_costmap / local_costmap (default: from the file)")
    sensor_grace: float | None = param(None, lo=0.0, hi=3600.0, unit="s",
                                       doc="time without sensor data before a warning")


def check_costmap_node(cfg: dict, source: str) -> list[str]:
    """The costmap node's parameters checked without the bus: every problem in one ConfigError;
    returns the no-effect notes (the agents call this before starting anything)."""
    problems = Problems()
    notes: list[str] = []
    p = None
    with problems.collect():
        p = load_params(CostmapNodeParams, cfg, source)
    if p is not None:
        base = Path(source).parent
        paths = {}
        for key in ("common", "specific"):
            path = base / getattr(p, key) if getattr(p, key) else None
            if path is None:
                problems.add(source, key, "path of the ROS costmap file is required")
            elif not path.is_file():
                problems.add(source, key, f"file not found: {path}")
            paths[key] = path
        if not problems:
            with problems.collect():
                load_costmap_files(paths["common"], paths["specific"], name=p.name, notes=notes)
    problems.raise_if_any()
    return notes
