"""Parameters of the robot-side collision monitor, named as nav2's collision_monitor names them.

A ROS 1 user has no collision monitor; a nav2 user can copy values. The YAML mapping::

    base_frame_id: base_link
    cmd_vel_in_topic: cmd_vel           # what the master sends
    cmd_vel_out_topic: safety/cmd_vel   # what the base driver listens to (its cmd_vel_topic)
    state_topic: collision_monitor/state
    transform_tolerance: 0.5
    source_timeout: 1.0                 # a source older than this stops the robot
    cmd_vel_timeout: 0.25               # an input command older than this is replaced by zero
    observation_sources: [scan]
    scan: {type: scan, topic: scan}
    polygons: [approach]
    approach: {type: polygon, action_type: approach, points: "[[0.33, 0.25], ...]",
               time_before_collision: 0.6, simulation_time_step: 0.05, min_points: 4}

A polygon's ``points`` is a list of [x, y] (or nav2's string form of it); ``type: circle`` takes
``radius`` instead. ``footprint`` (the robot polygon, as in costmap_common_params.yaml) grown by
``footprint_padding`` is the shape of a polygon without ``points``.
"""

from __future__ import annotations

import ast
import math
from dataclasses import dataclass

from common.config import ConfigError, Problems, load_params, param

__all__ = ["MonitorParams", "PolygonParams", "SourceParams", "load_monitor", "padded"]

ACTIONS = ("stop", "slowdown", "limit", "approach")


@dataclass(frozen=True)
class MonitorParams:
    base_frame_id: str = param("base_link", doc="robot frame: polygons are in it")
    odom_frame_id: str = param("odom", doc="frame the points are kept in between scans (robot motion "
                                           "since a scan is taken into account)")
    cmd_vel_in_topic: str = param("cmd_vel", doc="commands from the master")
    cmd_vel_out_topic: str = param("safety/cmd_vel", doc="commands to the base driver")
    state_topic: str = param("collision_monitor/state", doc="the action taken and why (latched)")
    transform_tolerance: float = param(0.5, lo=0.0, hi=10.0, unit="s", doc="TF wait for a source's frame")
    source_timeout: float = param(1.0, lo=0.05, hi=60.0, unit="s",
                                  doc="a source silent this long stops the robot (no data, no motion)")
    cmd_vel_timeout: float = param(0.25, lo=0.01, hi=60.0, unit="s",
                                   doc="an input command older than this is replaced by an explicit zero")
    stop_pub_timeout: float = param(0.5, lo=0.0, hi=60.0, unit="s",
                                    doc="zero commands keep being sent this long after a stop")
    state_rate: float = param(2.0, lo=0.1, hi=100.0, unit="Hz", doc="state republished at this rate")
    footprint: tuple[tuple[float, float], ...] | None = param(None, unit="m",
                                                              doc="robot polygon; default of approach polygons")
    footprint_padding: float = param(0.03, lo=0.0, hi=1.0, unit="m",
                                     doc="footprint grown by this much (as costmap_2d pads it)")
    observation_sources: tuple[str, ...] = param(("scan",), doc="names of source mappings")
    polygons: tuple[str, ...] = param(("approach",), doc="names of polygon mappings, checked in turn")
    enabled: bool = param(True, doc="false: commands pass through unchanged (state says so)")
    rotation_center_x: float = param(
        0.0, lo=-2.0, hi=2.0, unit="m",
        doc="zenav: where on base_link's x axis the base turns about; approach polygons are predicted with "
            "base_link sliding sideways at -rotation_center_x * w, as DWA's rotation_center_x. 0: about "
            "base_link (nav2). A skid-steered base pivots toward its more loaded axle: `python bench/turning.py`")


@dataclass(frozen=True)
class SourceParams:
    type: str = param("scan", choices=("scan",), doc="LaserScan (a depth camera reaches us as a scan)")
    topic: str = param("scan", doc="the robot's own scan topic")
    min_height: float = param(0.05, no_effect=True, doc="accepted; a planar scan has no height")
    max_height: float = param(0.5, no_effect=True, doc="accepted; a planar scan has no height")
    enabled: bool = param(True, doc="false: ignored")
    blind_zone_memory: float = param(5.0, lo=0.0, hi=600.0, unit="s",
                                     doc="zenav: points that left the sensor's view are remembered (in odom) "
                                         "while their beam returns nothing, and this long outside the field "
                                         "of view or when hidden; 0 = no memory")


@dataclass(frozen=True)
class PolygonParams:
    type: str = param("polygon", choices=("polygon", "circle"), doc="shape")
    action_type: str = param("approach", choices=ACTIONS, doc="what the monitor does when points are inside")
    points: tuple[tuple[float, float], ...] | None = param(None, unit="m", doc="polygon corners in base frame")
    radius: float | None = param(None, lo=0.001, hi=50.0, unit="m", doc="circle radius")
    min_points: int = param(4, lo=1, hi=100000, doc="points inside before the action applies (noise)")
    slowdown_ratio: float = param(0.5, lo=0.0, hi=1.0, doc="slowdown: speed factor")
    linear_limit: float = param(0.5, lo=0.0, hi=10.0, unit="m/s", doc="limit: max |v|")
    angular_limit: float = param(0.5, lo=0.0, hi=20.0, unit="rad/s", doc="limit: max |w|")
    time_before_collision: float = param(0.6, lo=0.01, hi=10.0, unit="s",
                                         doc="approach: the commanded motion may not reach an obstacle sooner")
    simulation_time_step: float = param(0.05, lo=0.005, hi=1.0, unit="s", doc="approach: prediction step")
    enabled: bool = param(True, doc="false: ignored")
    visualize: bool = param(False, no_effect=True, doc="accepted; the monitor draws the state instead")
    polygon_pub_topic: str = param("", no_effect=True, doc="accepted; not published")

    def validate(self) -> None:
        if self.type == "circle" and self.radius is None:
            raise ValueError("a circle needs 'radius'")
        if self.points is not None and len(self.points) < 3:
            raise ValueError("'points' needs at least 3 corners")
        if self.points is not None and not all(math.isfinite(v) for p in self.points for v in p):
            raise ValueError("'points' must be finite")


def _points(value, source: str, key: str):
    """nav2 writes points as a string "[[x, y], ...]"; accept that or a YAML list."""
    if isinstance(value, str):
        try:
            value = ast.literal_eval(value)
        except (ValueError, SyntaxError) as e:
            raise ConfigError(source, key, f"not a list of [x, y] points: {e}") from None
    return value


def load_monitor(cfg: dict | None, source: str, notes: list | None = None):
    """(MonitorParams, {name: SourceParams}, [(name, PolygonParams)]) or one ConfigError with every problem."""
    cfg = dict(cfg or {})
    for key in ("footprint",):
        if key in cfg:
            cfg[key] = _points(cfg[key], source, key)
    problems = Problems()
    names = {}
    for key, default in (("observation_sources", ("scan",)), ("polygons", ("approach",))):
        v = cfg.get(key, default)
        names[key] = [str(n) for n in v] if isinstance(v, (list, tuple)) else []
    mp = MonitorParams()
    with problems.collect():
        subs = set(names["observation_sources"]) | set(names["polygons"])
        mp = load_params(MonitorParams, {k: v for k, v in cfg.items() if k not in subs}, source, notes=notes)
    sources, polys = {}, []
    for name in names["observation_sources"]:
        with problems.collect():
            if not isinstance(cfg.get(name, {}), dict):
                raise ConfigError(source, name, "expected a mapping (type, topic)")
            sources[name] = load_params(SourceParams, cfg.get(name), source, name, notes=notes)
    for name in names["polygons"]:
        with problems.collect():
            sub = cfg.get(name)
            if not isinstance(sub, dict):
                raise ConfigError(source, name, "missing: each name in 'polygons' needs a mapping")
            sub = dict(sub)
            if "points" in sub:
                sub["points"] = _points(sub["points"], source, f"{name}.points")
            pp = load_params(PolygonParams, sub, source, name, notes=notes)
            if pp.type == "polygon" and pp.points is None and mp.footprint is None and "footprint" not in cfg:
                raise ConfigError(source, f"{name}.points", "missing (or give the monitor a 'footprint')")
            polys.append((name, pp))
    if problems:
        raise ConfigError.of(problems.items)
    return mp, sources, polys


def padded(points, padding: float) -> tuple[tuple[float, float], ...]:
    """costmap_2d's padFootprint: each corner moved ``padding`` away from the axes in x and in y."""
    return tuple((x + math.copysign(padding, x) if x else x, y + math.copysign(padding, y) if y else y)
                 for x, y in points)
