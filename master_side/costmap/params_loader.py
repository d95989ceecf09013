"""One costmap namespace sorted into the costmap level, its layers and their observation sources.

``NamespaceLoader`` does the work behind ``master_side.costmap.params.load_costmap_config``: it derives
the layers (pre-Hydro flat keys or a ``plugins`` list), copies costmap-level keys into the layers and
sources that read them, loads each parameter group, and keeps every problem and no-effect note.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

from common.config import ConfigError, Note, Problems, load_params, strip_frame
from master_side.costmap.layer_params import (
    FLAT_LAYER_KEYS,
    INFLATION_KEYS,
    OBSTACLE_KEYS,
    PARENT_KEYS,
    SOURCE_INHERITED_KEYS,
    STATIC_KEYS,
    VOXEL_KEYS,
    CostmapParams,
    ObservationSourceParams,
    Origins,
)
from master_side.costmap.layered import layer_class
from master_side.costmap.obstacle_layer import ObstacleLayer
from master_side.ros_params import (
    ALL_KEYS,
    COSTMAP,
    NAV2_COSTMAP,
    OBSERVATION_SOURCE,
    accepted_names,
    no_effect_keys,
)

_PRE_HYDRO_ONLY = ("static_map", "map_type", "observation_sources")
_STRUCTURAL = ("plugin", "type")  # nav2 / zenav layer keys naming the plugin, not parameters
_COSTMAP_COMPONENTS = (COSTMAP, NAV2_COSTMAP)


@dataclass(frozen=True)
class LayerSpec:
    name: str
    type: str  # plugin type name, e.g. "costmap_2d::InflationLayer"
    params: Any
    sources: tuple[tuple[str, ObservationSourceParams], ...] | None = None  # obstacle / voxel layers


class NamespaceLoader:
    """One costmap namespace: which keys go where, the problems found and the notes."""

    def __init__(self, merged: dict, origins: Origins):
        self.m, self.origins = merged, origins
        self.problems = Problems()
        self.notes: list[str] = []
        self.ignored: list[str] = []
        self.consumed: set[str] = set()       # costmap-level keys read by a layer / source
        self.reasons: dict[str, str] = {}     # costmap-level key -> why it has no effect here

    def load(self, cls: type, mapping: dict, section: str, components: tuple[str, ...],
             ignore: frozenset[str] | set[str] = frozenset(), extra: dict[str, str] | None = None) -> Any:
        found: list = []
        no_effect = {**no_effect_keys(components, cls), **(extra or {})}
        try:
            obj = load_params(cls, mapping, "", section, ignore=tuple(ignore), no_effect=no_effect, notes=found)
        except ConfigError as e:
            self.problems.items.extend(self.origins.error(k, why) for _s, k, why in e.problems)
            return None
        for n in found:
            self.note(n.key, n.why)
        return obj

    def note(self, key: str, why: str) -> None:
        self.notes.append(Note(*self.origins.error(key, why)))
        self.ignored.append(".".join(self.origins.as_written(key)))

    def flat_layers(self) -> list[tuple[str, str, dict]]:
        """The layers costmap_2d derives from pre-Hydro parameters (Costmap2DROS::loadOldParameters)."""
        m, layers = self.m, []
        sources = str(m.get("observation_sources", "")).split()
        for layer in ("static_layer", "obstacle_layer", "inflation_layer"):
            for k in (*FLAT_LAYER_KEYS, "track_unknown_space", *sources):
                if k in m:
                    self.origins.moved[(layer, k)] = (k,)
        static, voxel = m.get("static_map") is True, m.get("map_type") == "voxel"
        if static:
            layers.append(("static_layer", "costmap_2d::StaticLayer",
                           self._move("static_layer", STATIC_KEYS + ("track_unknown_space",))))
        moved = OBSTACLE_KEYS + ("track_unknown_space",) + (VOXEL_KEYS if voxel else ()) + tuple(sources)
        layers.append(("obstacle_layer", "costmap_2d::VoxelLayer" if voxel else "costmap_2d::ObstacleLayer",
                       self._move("obstacle_layer", moved)))
        layers.append(("inflation_layer", "costmap_2d::InflationLayer", self._move("inflation_layer",
                                                                                   INFLATION_KEYS)))
        self.consumed |= set(SOURCE_INHERITED_KEYS)
        if not voxel:
            self.reasons.update({k: "no effect (used only with map_type: voxel)" for k in VOXEL_KEYS})
        if not static:
            self.reasons.update({k: "no effect (used only with static_map: true)" for k in STATIC_KEYS})
        return layers

    def _move(self, layer: str, keys: tuple[str, ...]) -> dict:
        d = dict(self.m.get(layer) or {})
        d.update({k: self.m[k] for k in keys if k in self.m})
        self.consumed.update(k for k in keys if k in self.m)
        return d

    def plugin_layers(self) -> list[tuple[str, str, dict]]:
        m, plugins = self.m, self.m["plugins"]
        if not isinstance(plugins, list):
            self.problems.add(*self.origins.error("plugins", f"expected a list of {{name, type}}, got {plugins!r}"))
            return []
        out, seen = [], set()
        for i, p in enumerate(plugins):
            if isinstance(p, dict) and set(p) <= {"name", "type", "enabled"} and "name" in p and "type" in p:
                name, kind = str(p["name"]), str(p["type"])
            elif isinstance(p, str) and isinstance(m.get(p), dict) and "plugin" in m[p]:
                name, kind = p, str(m[p]["plugin"])  # nav2: plugins: [name, ...], name.plugin: type
            else:
                self.problems.add(*self.origins.error(f"plugins[{i}]", f"expected {{name: ..., type: ...}}, got {p!r}"))
                continue
            if name in seen:
                self.problems.add(*self.origins.error(f"plugins[{i}]", f"layer name {name!r} used twice"))
                continue
            seen.add(name)
            try:
                layer_class(kind)
            except KeyError as e:
                self.problems.add(*self.origins.error(f"plugins[{i}].type", str(e.args[0])))
                continue
            raw = m.get(name, {})
            if not isinstance(raw, dict):
                self.problems.add(*self.origins.error(name, f"layer parameters must be a mapping, got {raw!r}"))
                continue
            out.append((name, kind, self._copy_parent(name, kind, dict(raw))))
        types = {kind for _n, kind, _r in out}
        for keys in PARENT_KEYS.values():
            for k in keys:
                if k not in self.consumed:
                    readers = [c for c, ks in PARENT_KEYS.items() if k in ks]
                    self.reasons[k] = ("no effect (read only by a " + " / ".join(readers) + "; plugins has none)")
        for k in _PRE_HYDRO_ONLY:
            self.reasons[k] = "no effect (a pre-Hydro parameter; plugins is given)"
        if any(issubclass(layer_class(kind), ObstacleLayer) for kind in types):
            self.consumed |= set(SOURCE_INHERITED_KEYS)  # found by the sources (searchParam)
        return out

    def _copy_parent(self, name: str, kind: str, raw: dict) -> dict:
        for k in PARENT_KEYS.get(kind, ()):  # ROS 1 type names only: nav2 does not copy
            if k not in self.m:
                continue
            if k in raw and raw[k] != self.m[k]:
                self.note(f"{name}.{k}", f"no effect (the costmap-level {k}: {self.m[k]!r} overrides it, "
                                         "as ROS copies it into the layer)")
            raw[k] = self.m[k]
            self.origins.moved[(name, k)] = (k,)
            self.consumed.add(k)
        return raw

    def costmap_level(self, flat: bool, layers_raw: list) -> CostmapParams | None:
        fields = accepted_names(CostmapParams)
        layer_names = {n for n, _t, _m in layers_raw}
        ignore = (self.consumed | layer_names) - fields
        extra = {k: why for k, why in self.reasons.items() if k not in ignore}
        for k, v in self.m.items():
            if isinstance(v, dict) and k not in fields and k not in ignore and k not in extra \
                    and not _is_catalogued(k):
                extra[k] = "no effect (no layer or observation source of this costmap has this name)"
        costmap = self.load(CostmapParams, self.m, "", _COSTMAP_COMPONENTS, ignore, extra)
        if not flat:
            for k in ("static_map", "map_type"):
                if k in self.m:
                    self.note(k, self.reasons[k])
        return costmap

    def layer_spec(self, name: str, kind: str, raw: dict) -> LayerSpec | None:
        cls = layer_class(kind)
        comps = (cls.type_names[0], NAV2_COSTMAP)
        if not issubclass(cls, ObstacleLayer):
            params = self.load(cls.Params, raw, name, comps, set(_STRUCTURAL), self._namespaces(cls.Params, raw))
            return LayerSpec(name, kind, params)
        names = str(raw.get("observation_sources", "")).split()
        params = self.load(cls.Params, raw, name, comps, set(_STRUCTURAL) | set(names),
                           self._namespaces(cls.Params, raw, "an observation source of this layer"))
        sources = []
        for s in names:
            src = raw.get(s, {})
            if not isinstance(src, dict):
                self.problems.add(*self.origins.error(f"{name}.{s}",
                                                      f"observation source must be a mapping, got {src!r}"))
                continue
            src = dict(src)
            for k in SOURCE_INHERITED_KEYS:
                if k not in src and raw.get(k) is not None:
                    src[k] = raw[k]
                    self.origins.moved[(name, s, k)] = (name, k)
                elif k not in src and k in self.m:
                    src[k] = self.m[k]
                    self.origins.moved[(name, s, k)] = (k,)
            sp = self.load(ObservationSourceParams, src, f"{name}.{s}", (OBSERVATION_SOURCE, NAV2_COSTMAP))
            if sp is not None:
                sources.append((s, dataclasses.replace(sp, topic=sp.topic or s,
                                                       sensor_frame=strip_frame(sp.sensor_frame))))
        return LayerSpec(name, kind, params, tuple(sources))

    @staticmethod
    def _namespaces(cls: type, raw: dict, what: str = "a parameter namespace of this layer") -> dict[str, str]:
        """Sub-mappings of a layer that nothing reads (e.g. a source not in observation_sources)."""
        fields = accepted_names(cls)
        return {k: f"no effect (not {what})" for k, v in raw.items()
                if isinstance(v, dict) and k not in fields and not _is_catalogued(k)}


def _is_catalogued(key: str) -> bool:
    return key in ALL_KEYS
