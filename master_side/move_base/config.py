"""Everything move_base reads, loaded and checked without the bus (used by the node and by the agents'
check before anything starts).

Node mapping (paths relative to the config file, or inline mappings)::

  move_base: move_base_params.yaml           # ROS move_base parameters
  local_planner: base_local_planner_params.yaml   # TrajectoryPlannerROS: / DWAPlannerROS: / RegulatedPurePursuit:
  global_planner: {}                         # NavfnROS: parameters (optional)
  costmap_common: costmap_common_params.yaml # footprint, padding
  local_costmap: local_costmap_params.yaml   # the controller's frame
  global_costmap: global_costmap_params.yaml # the planner's frame (optional: else the costmap's message)

Every problem of every file in one ConfigError; ROS parameters without effect in ``notes``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from common.config import Problems, include, include_chain, load_params, strip_frame
from common.geometry import footprint_radii
from master_side import ros_params as ros
from master_side.costmap.footprint import pad_footprint
from master_side.costmap.params import CostmapConfig, load_costmap_config
from master_side.move_base.escape import ESCAPE_TYPES, EscapeParams
from master_side.move_base.params import MoveBaseParams
from master_side.move_base.recovery import RotateLimits
from master_side.planning.local.base import LocalPlannerPlugin
from master_side.planning.local.dwa import DWAPlanner, DWAPlannerParams
from master_side.planning.local.pure_pursuit import PurePursuitParams, RegulatedPurePursuit
from master_side.planning.local.trajectory_planner import TrajectoryPlanner, TrajectoryPlannerParams
from master_side.planning.navfn import NavfnParams

NODE_KEYS = ("move_base", "local_planner", "global_planner", "costmap_common", "local_costmap", "global_costmap")
DEFAULT_RECOVERY_NAMES = ("conservative_reset", "rotate_recovery", "aggressive_reset")


def _local_planners() -> dict[str, tuple[str, type, type, str]]:
    """base_local_planner value -> (YAML section, params class, planner class, ROS component)."""
    out = {"dwa_local_planner/DWAPlannerROS": ("DWAPlannerROS", DWAPlannerParams, DWAPlanner, ros.DWA_LOCAL_PLANNER),
           "base_local_planner/TrajectoryPlannerROS": ("TrajectoryPlannerROS", TrajectoryPlannerParams,
                                                       TrajectoryPlanner, ros.BASE_LOCAL_PLANNER)}
    out["zenav/RegulatedPurePursuit"] = ("RegulatedPurePursuit", PurePursuitParams, RegulatedPurePursuit, "")
    return out


@dataclass(frozen=True)
class MoveBaseConfig:
    params: MoveBaseParams
    local_kind: str  # base_local_planner value
    local_params: Any  # the local planner's parameter dataclass
    navfn: NavfnParams
    local_costmap: CostmapConfig
    global_costmap: CostmapConfig | None
    recovery_namespaces: dict
    rotate: RotateLimits
    source: str
    notes: tuple[str, ...] = field(default=())

    @property
    def footprint(self) -> np.ndarray:
        """The padded footprint the planners check (Costmap2DROS::getRobotFootprint)."""
        return np.asarray(self.local_costmap.footprint, float)

    @property
    def local_frame(self) -> str:
        return self.local_costmap.costmap.global_frame

    @property
    def global_frame(self) -> str | None:
        return self.global_costmap.costmap.global_frame if self.global_costmap else None

    @property
    def base_frame(self) -> str:
        return strip_frame((self.global_costmap or self.local_costmap).costmap.robot_base_frame)

    @property
    def transform_tolerance(self) -> float:
        return (self.global_costmap or self.local_costmap).costmap.transform_tolerance

    @property
    def bare_footprint(self) -> np.ndarray:
        """The robot's own outline: the local costmap's footprint with its padding taken off again."""
        return pad_footprint(self.footprint, -self.local_costmap.costmap.footprint_padding)

    @property
    def rotation_center_x(self) -> float:
        """Where the base turns about (the local planner's ``rotation_center_x``; 0 for planners without it)."""
        return float(getattr(self.local_params, "rotation_center_x", 0.0))

    @property
    def circumscribed_radius(self) -> float:
        return float(footprint_radii(self.footprint)[1])

    def make_local_planner(self) -> LocalPlannerPlugin:
        planner = _local_planners()[self.local_kind][2](self.local_params)
        planner.footprint_padding = self.local_costmap.costmap.footprint_padding
        return planner


def _or_empty(found: tuple[dict[str, Any], str] | None, source: str) -> tuple[dict[str, Any], str]:
    """An included file's (mapping, source), or an empty mapping from ``source`` when it is not given."""
    return found or ({}, source)


def _collect(problems: Problems, fn, *args, **kw) -> Any:
    with problems.collect():
        return fn(*args, **kw)
    return None


def load_move_base_config(cfg: dict, source: str) -> MoveBaseConfig:
    problems = Problems()
    notes: list[str] = []
    for k in sorted(set(cfg) - set(NODE_KEYS)):
        problems.add(source, k, f"unknown key (known: {', '.join(NODE_KEYS)})")
    files: dict[str, Any] = {k: _collect(problems, include, cfg.get(k), source, k) for k in NODE_KEYS}
    mb, mb_src = _or_empty(files["move_base"], source)
    with problems.collect():  # zenav: another move_base file as the base, this one's keys over it (a recovery's
        mb, mb_src = include_chain(mb, mb_src)  # namespace merged key by key)
    mb = {k: v for k, v in mb.items() if k != "include"}  # a refused include: reported above, not again
    rec_names = set(DEFAULT_RECOVERY_NAMES)
    if isinstance(mb.get("recovery_behaviors"), list):
        rec_names |= {str(b.get("name")) for b in mb["recovery_behaviors"] if isinstance(b, dict)}
    namespaces = {k: v for k, v in mb.items() if k in rec_names and isinstance(v, dict)}
    for b in mb.get("recovery_behaviors") or []:  # an escape's parameters are zenav's: checked before start
        if isinstance(b, dict) and b.get("type") in ESCAPE_TYPES:
            _collect(problems, load_params, EscapeParams, namespaces.get(str(b.get("name"))), mb_src, str(b["name"]))
    # keys of the planners / costmaps a move_base namespace may also hold (ROS loads them all into ~)
    nested = {"global_costmap", "local_costmap", "TrajectoryPlannerROS", "DWAPlannerROS", "NavfnROS",
              "GlobalPlanner", *namespaces}
    params = _collect(problems, ros.load_ros_params, MoveBaseParams, {k: v for k, v in mb.items() if k not in nested},
                      mb_src, "", ros.MOVE_BASE, notes)
    kinds = _local_planners()
    kind = params.base_local_planner if params else "base_local_planner/TrajectoryPlannerROS"
    section, pcls, _, component = kinds[kind]
    lp, lp_src = _or_empty(files["local_planner"], source)
    data = dict(lp.get(section, lp if section not in lp and lp else {}) or {})
    with problems.collect():  # zenav: another planner file's section as the base, this one's keys over it
        data, lp_src = include_chain(data, lp_src, section, merge=lambda base, over: {**base, **over})
    data.pop("include", None)
    others = [s for s, *_ in kinds.values() if s != section and s in lp]
    for s in others:
        notes.append(f"{lp_src}: {s}: section of another local planner; no effect (base_local_planner is {kind})")
    if params and "controller_frequency" not in data:  # ROS: the planner finds move_base's by searchParam
        data["controller_frequency"] = params.controller_frequency
    if component:
        local_params = _collect(problems, ros.load_ros_params, pcls, data, lp_src, section, component, notes)
    else:  # zenav's own planner: every key must be one of its parameters
        local_params = _collect(problems, load_params, pcls, data, lp_src, section)
    gp, gp_src = _or_empty(files["global_planner"], source)
    navfn = _collect(problems, ros.load_ros_params, NavfnParams, gp.get("NavfnROS", gp) or {}, gp_src,
                     "NavfnROS", ros.NAVFN, notes)
    common, c_src = _or_empty(files["costmap_common"], source)
    local, l_src = _or_empty(files["local_costmap"], source)
    lc = _collect(problems, load_costmap_config, common, local, (c_src, l_src), name="local_costmap")
    gc = None
    if cfg.get("global_costmap") is not None and files["global_costmap"]:
        glob, g_src = files["global_costmap"]
        gc = _collect(problems, load_costmap_config, common, glob, (c_src, g_src), name="global_costmap")
    problems.raise_if_any()
    rotate = RotateLimits(**{k: v for k, v in (
        ("max_rotational_vel", getattr(local_params, "max_rotational_vel", None)),
        ("min_in_place_rotational_vel", getattr(local_params, "min_in_place_vel_theta", None)),
        ("acc_lim_th", getattr(local_params, "acc_lim_theta", None)),
        ("yaw_goal_tolerance", getattr(local_params, "yaw_goal_tolerance", None))) if v is not None}) \
        if section == "TrajectoryPlannerROS" else RotateLimits()
    if section == "RegulatedPurePursuit":
        rotate = RotateLimits(local_params.max_angular_vel, local_params.min_in_place_vel_theta,
                              local_params.acc_lim_theta, local_params.yaw_goal_tolerance)
    return MoveBaseConfig(params, kind, local_params, navfn, lc, gc, namespaces, rotate, source, tuple(notes))


def check(cfg: dict, source: str) -> list[str]:
    """Agent pre-start check: load everything, raise on any problem, return the no-effect notes."""
    return list(load_move_base_config(cfg or {}, source).notes)
