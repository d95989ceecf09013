"""Layer contract (costmap_2d::Layer / CostmapLayer, nav2's Layer) and the type-name -> class registry.

Each cycle the LayeredCostmap calls ``update_bounds(robot_pose, bounds) -> bounds`` on every enabled
layer, then ``update_costs(master, window)`` over the window of cells that changed. ``CostmapPlugin``
is the whole contract as a Protocol; ``Layer`` implements each hook as a no-op (a layer overrides what
it uses) and a layer changes only its own state: the master grid only in ``update_costs``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar, Protocol

import numpy as np

from common.geometry import Pose2D
from master_side.costmap.cost_values import FREE, NO_INFORMATION
from master_side.costmap.costmap2d import Costmap2D, Window

if TYPE_CHECKING:
    from master_side.costmap.layered import LayeredCostmap


@dataclass(frozen=True)
class Bounds:
    """A world-frame rectangle (metres); empty when min > max."""

    min_x: float = math.inf
    min_y: float = math.inf
    max_x: float = -math.inf
    max_y: float = -math.inf

    def is_empty(self) -> bool:
        return self.min_x > self.max_x or self.min_y > self.max_y

    def expand(self, min_x: float, min_y: float, max_x: float, max_y: float) -> Bounds:
        return Bounds(min(self.min_x, min_x), min(self.min_y, min_y), max(self.max_x, max_x),
                      max(self.max_y, max_y))

    def expand_points(self, xs: np.ndarray, ys: np.ndarray) -> Bounds:
        if np.size(xs) == 0:
            return self
        return self.expand(float(np.min(xs)), float(np.min(ys)), float(np.max(xs)), float(np.max(ys)))

    def padded(self, margin: float) -> Bounds:
        if self.is_empty():
            return self
        return Bounds(self.min_x - margin, self.min_y - margin, self.max_x + margin, self.max_y + margin)


LAYER_TYPES: dict[str, type[Layer]] = {}


def register_layer(*type_names: str):
    """Class decorator: register a layer under its plugin type names; refuses duplicates."""

    def deco(cls):
        for n in type_names:
            if n in LAYER_TYPES:
                raise ValueError(f"costmap layer type {n!r} registered twice "
                                 f"({LAYER_TYPES[n].__name__} and {cls.__name__})")
        for n in type_names:
            LAYER_TYPES[n] = cls
        cls.type_names = tuple(type_names)
        return cls

    return deco


def layer_class(type_name: str) -> type[Layer]:
    try:
        return LAYER_TYPES[type_name]
    except KeyError:
        raise KeyError(f"unknown costmap layer type {type_name!r}; known: {sorted(LAYER_TYPES)}") from None


class CostmapPlugin(Protocol):
    """What the LayeredCostmap calls on each of its layers."""

    name: str

    @property
    def enabled(self) -> bool: ...

    def initialize(self, layered: LayeredCostmap) -> None:
        """Added to ``layered`` (the master grid exists)."""

    def match_size(self) -> None: ...

    def update_origin(self, new_origin_x: float, new_origin_y: float) -> None: ...

    def on_footprint_changed(self) -> None: ...

    def update_bounds(self, robot_pose: Pose2D, bounds: Bounds) -> Bounds: ...

    def update_costs(self, master: Costmap2D, window: Window) -> None: ...

    def reset(self) -> None: ...

    def clear_outside(self, outside: np.ndarray) -> None: ...

    def is_current(self, now: float) -> bool: ...

    def stale_sources(self, now: float) -> list[str]: ...

    def grid(self) -> Costmap2D | None: ...


class Layer:
    """A plugin layer. Subclasses set ``Params`` (a frozen params dataclass) and override the hooks."""

    Params: ClassVar[type]
    type_names: ClassVar[tuple[str, ...]] = ()

    def __init__(self, name: str, params: Any):
        self.name = name
        self.params = params
        self.layered: LayeredCostmap | None = None

    @property
    def enabled(self) -> bool:
        return bool(getattr(self.params, "enabled", True))

    def initialize(self, layered: LayeredCostmap) -> None:
        self.layered = layered
        self.match_size()

    def match_size(self) -> None:
        """The master grid was resized / created."""

    def update_origin(self, new_origin_x: float, new_origin_y: float) -> None:
        """Rolling window: the master moved to a new origin."""

    def on_footprint_changed(self) -> None:
        """The footprint (and so the inscribed radius) changed."""

    def update_bounds(self, robot_pose: Pose2D, bounds: Bounds) -> Bounds:
        return bounds

    def update_costs(self, master: Costmap2D, window: Window) -> None:
        """Write this layer's contribution into ``master`` over ``window``."""

    def reset(self) -> None:
        """Forget everything (move_base recovery 'clear costmaps')."""

    def clear_outside(self, outside: np.ndarray) -> None:
        """ClearCostmapRecovery: forget what this layer learnt from sensors in the master's cells where
        ``outside`` (bool, (size_y, size_x)) is True; a layer without sensor data keeps everything."""

    def is_current(self, now: float) -> bool:
        """ROS isCurrent: are this layer's inputs recent enough (no inputs: always)?"""
        return True

    def stale_sources(self, now: float) -> list[str]:
        """Names of the inputs that make this layer not current."""
        return []

    def grid(self) -> Costmap2D | None:
        """This layer's own grid for display (None if it has none)."""
        return None


class CostmapLayer(Layer):
    """A layer with its own grid aligned with the master (same size, resolution and origin)."""

    def __init__(self, name: str, params: Any):
        super().__init__(name, params)
        self.costmap: Costmap2D | None = None

    def track_unknown(self) -> bool:
        value = getattr(self.params, "track_unknown_space", None)
        return self.layered.track_unknown_space if value is None else bool(value)

    def default_value(self) -> int:
        return NO_INFORMATION if self.track_unknown() else FREE

    def match_size(self) -> None:
        m = self.layered.master
        value = self.default_value()
        self.costmap = Costmap2D(m.size_x, m.size_y, m.resolution, m.origin_x, m.origin_y, value)

    def update_origin(self, new_origin_x: float, new_origin_y: float) -> None:
        self.costmap.update_origin(new_origin_x, new_origin_y)

    def reset(self) -> None:
        self.costmap.reset()

    def grid(self) -> Costmap2D | None:
        return self.costmap
