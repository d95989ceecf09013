"""Catalogue of the ROS 1 navigation parameters (noetic), so a user's ROS files load into zenav unchanged.

For each ROS component, the names it reads: its dynamic_reconfigure ``cfg`` entries and the
``param`` / ``getParam`` / ``searchParam`` / ``hasParam`` reads of its sources, with the deprecated
names it still accepts. A key in a zenav parameter mapping is then one of:

- a field (or alias) of the zenav dataclass: loaded and checked;
- a parameter of the same ROS component that zenav does not implement: accepted, reported as
  "no effect (not implemented in zenav)";
- a parameter of another ROS component (``meter_scoring`` in a costmap file): accepted, as ROS silently
  ignores it there, reported as "no effect here (a base_local_planner parameter)";
- known to no ROS component: an error with a did-you-mean.

Usage (the loaders of move_base, the planners and the recovery behaviours)::

    notes: list[str] = []
    p = load_ros_params(TrajectoryPlannerParams, mapping, source, "TrajectoryPlannerROS",
                        BASE_LOCAL_PLANNER, notes)          # raises one ConfigError with every problem

Data and small helpers only (no bus).
"""

from __future__ import annotations

import dataclasses
import functools
from typing import Any, Iterable, Mapping

from common.config import load_params

MOVE_BASE = "move_base"
COSTMAP = "costmap_2d"                            # Costmap2DROS, including the pre-Hydro flat keys
STATIC_LAYER = "costmap_2d::StaticLayer"
OBSTACLE_LAYER = "costmap_2d::ObstacleLayer"
VOXEL_LAYER = "costmap_2d::VoxelLayer"
INFLATION_LAYER = "costmap_2d::InflationLayer"
OBSERVATION_SOURCE = "costmap_2d observation source"
NAVFN = "navfn"                                   # navfn/NavfnROS
GLOBAL_PLANNER = "global_planner"                 # global_planner/GlobalPlanner
BASE_LOCAL_PLANNER = "base_local_planner"         # base_local_planner/TrajectoryPlannerROS
DWA_LOCAL_PLANNER = "dwa_local_planner"           # dwa_local_planner/DWAPlannerROS
CLEAR_COSTMAP_RECOVERY = "clear_costmap_recovery"
ROTATE_RECOVERY = "rotate_recovery"
NAV2_COSTMAP = "nav2_costmap_2d"                  # ROS 2 keys zenav's costmap loader also accepts


def _k(text: str) -> frozenset[str]:
    return frozenset(text.split())


_OBSTACLE = _k("""enabled footprint_clearing_enabled max_obstacle_height combination_method track_unknown_space
    transform_tolerance observation_sources obstacle_range raytrace_range""")
_VOXEL_ONLY = _k("origin_z z_resolution z_voxels unknown_threshold mark_threshold publish_voxel_map")
_LOCAL_PLANNER_LIMITS = _k("""max_vel_trans min_vel_trans max_vel_x min_vel_x max_vel_y min_vel_y max_vel_theta
    min_vel_theta acc_lim_x acc_lim_y acc_lim_theta acc_lim_trans prune_plan xy_goal_tolerance yaw_goal_tolerance
    trans_stopped_vel theta_stopped_vel""")

COMPONENTS: dict[str, frozenset[str]] = {
    MOVE_BASE: _k("""base_global_planner base_local_planner recovery_behaviors planner_frequency controller_frequency
        planner_patience controller_patience max_planning_retries conservative_reset_dist recovery_behavior_enabled
        clearing_rotation_allowed shutdown_costmaps oscillation_timeout oscillation_distance make_plan_clear_costmap
        make_plan_add_unreachable_goal clearing_radius restore_defaults"""),
    COSTMAP: _k("""global_frame robot_base_frame transform_tolerance update_frequency publish_frequency width height
        resolution origin_x origin_y footprint robot_radius footprint_padding rolling_window track_unknown_space
        always_send_full_costmap plugins footprint_topic published_footprint_topic published_footprint
        inscribed_radius circumscribed_radius
        static_map map_type map_topic unknown_cost_value lethal_cost_threshold max_obstacle_height obstacle_range
        raytrace_range observation_sources cost_scaling_factor inflation_radius""") | _VOXEL_ONLY,
    STATIC_LAYER: _k("""enabled map_topic first_map_only subscribe_to_updates track_unknown_space use_maximum
        lethal_cost_threshold unknown_cost_value trinary_costmap"""),
    OBSTACLE_LAYER: _OBSTACLE,
    VOXEL_LAYER: _OBSTACLE | _VOXEL_ONLY,
    INFLATION_LAYER: _k("enabled inflation_radius cost_scaling_factor inflate_unknown"),
    OBSERVATION_SOURCE: _k("""topic sensor_frame observation_persistence expected_update_rate data_type clearing
        marking max_obstacle_height min_obstacle_height obstacle_range raytrace_range inf_is_valid"""),
    NAVFN: _k("allow_unknown planner_window_x planner_window_y default_tolerance visualize_potential"),
    GLOBAL_PLANNER: _k("""lethal_cost neutral_cost cost_factor publish_potential orientation_mode
        orientation_window_size old_navfn_behavior use_quadratic use_dijkstra use_grid_path allow_unknown
        planner_window_x planner_window_y default_tolerance publish_scale outline_map visualize_potential"""),
    BASE_LOCAL_PLANNER: _k("""inscribed_radius circumscribed_radius acc_lim_x acc_lim_y acc_lim_theta max_vel_x
        min_vel_x max_vel_theta min_vel_theta min_in_place_vel_theta sim_time sim_granularity
        angular_sim_granularity path_distance_bias goal_distance_bias occdist_scale oscillation_reset_dist
        escape_reset_dist escape_reset_theta vx_samples vtheta_samples heading_lookahead holonomic_robot escape_vel
        dwa heading_scoring heading_scoring_timestep simple_attractor y_vels restore_defaults prune_plan
        yaw_goal_tolerance xy_goal_tolerance stop_time_buffer latch_xy_goal_tolerance controller_frequency
        meter_scoring pdist_scale gdist_scale max_rotational_vel min_in_place_rotational_vel backup_vel
        acc_lim_th world_model point_grid publish_cost_grid_pc global_frame_id"""),
    DWA_LOCAL_PLANNER: _LOCAL_PLANNER_LIMITS | _k("""sim_time sim_granularity angular_sim_granularity
        path_distance_bias goal_distance_bias occdist_scale twirling_scale stop_time_buffer oscillation_reset_dist
        oscillation_reset_angle forward_point_distance scaling_speed max_scaling_factor vx_samples vy_samples
        vth_samples use_dwa restore_defaults sum_scores publish_cost_grid_pc publish_traj_pc global_frame_id
        cheat_factor odom_topic controller_frequency latch_xy_goal_tolerance max_trans_vel min_trans_vel
        max_rot_vel min_rot_vel acc_limit_trans rot_stopped_vel acc_lim_th publish_cost_grid"""),
    CLEAR_COSTMAP_RECOVERY: _k("reset_distance invert_area_to_clear force_updating affected_maps layer_names"),
    # its own namespace; it also reads acc_lim_theta, max_vel_theta, min_in_place_vel_theta and
    # yaw_goal_tolerance from TrajectoryPlannerROS's
    ROTATE_RECOVERY: _k("sim_granularity frequency"),
    NAV2_COSTMAP: _k("""use_sim_time clearable_layers filters initial_transform_timeout introspection_mode
        map_vis_z robot_radius_topic subscribe_to_stamped_footprint allow_parameter_qos_overrides
        map_subscribe_transient_local inflate_around_unknown obstacle_max_range obstacle_min_range
        raytrace_max_range raytrace_min_range"""),
}

# deprecated name -> current name, per component (ROS still reads the old one, with a warning)
DEPRECATED: dict[str, dict[str, str]] = {
    BASE_LOCAL_PLANNER: {"pdist_scale": "path_distance_bias", "gdist_scale": "goal_distance_bias",
                         "max_rotational_vel": "max_vel_theta", "backup_vel": "escape_vel",
                         "min_in_place_rotational_vel": "min_in_place_vel_theta", "acc_lim_th": "acc_lim_theta"},
    DWA_LOCAL_PLANNER: {"max_trans_vel": "max_vel_trans", "min_trans_vel": "min_vel_trans",
                        "max_rot_vel": "max_vel_theta", "min_rot_vel": "min_vel_theta",
                        "acc_limit_trans": "acc_lim_trans", "rot_stopped_vel": "theta_stopped_vel",
                        "acc_lim_th": "acc_lim_theta"},
}

# keys a component looks for only to warn that they are misspelt (ROS runs on, without them)
MISSPELT: dict[str, dict[str, str]] = {
    BASE_LOCAL_PLANNER: {"acc_limit_x": "acc_lim_x", "acc_limit_y": "acc_lim_y", "acc_limit_th": "acc_lim_theta"},
}

# ROS plugin / type names -> component (move_base's base_*_planner values, costmap plugin types)
PLUGIN_COMPONENT = {
    "navfn/NavfnROS": NAVFN, "global_planner/GlobalPlanner": GLOBAL_PLANNER,
    "base_local_planner/TrajectoryPlannerROS": BASE_LOCAL_PLANNER,
    "dwa_local_planner/DWAPlannerROS": DWA_LOCAL_PLANNER,
    "clear_costmap_recovery/ClearCostmapRecovery": CLEAR_COSTMAP_RECOVERY,
    "rotate_recovery/RotateRecovery": ROTATE_RECOVERY,
    "costmap_2d::StaticLayer": STATIC_LAYER, "costmap_2d::ObstacleLayer": OBSTACLE_LAYER,
    "costmap_2d::VoxelLayer": VOXEL_LAYER, "costmap_2d::InflationLayer": INFLATION_LAYER,
}

# move_base's default recovery behaviours (used without ``recovery_behaviors``): namespace -> component
DEFAULT_RECOVERIES = {"conservative_reset": CLEAR_COSTMAP_RECOVERY, "rotate_recovery": ROTATE_RECOVERY,
                      "aggressive_reset": CLEAR_COSTMAP_RECOVERY}

ALL_KEYS: frozenset[str] = frozenset().union(*COMPONENTS.values())


def owners(key: str) -> tuple[str, ...]:
    """The components that read ``key`` (catalogue order)."""
    return tuple(c for c, keys in COMPONENTS.items() if key in keys)


def accepted_names(cls: type | None) -> frozenset[str]:
    """Field names and aliases of a params dataclass."""
    if cls is None:
        return frozenset()
    out = set()
    for f in dataclasses.fields(cls):
        out.add(f.name)
        out.update(f.metadata.get("aliases", ()))
    return frozenset(out)


def other_component_reason(key: str, exclude: Iterable[str] = ()) -> str:
    """'no effect here (a base_local_planner parameter)' for a key of other components, or ''."""
    who = [c for c in owners(key) if c not in set(exclude)]
    if not who:
        return ""
    shown = " / ".join(who[:3]) + (" / ..." if len(who) > 3 else "")
    return f"no effect here (a {shown} parameter)"


@functools.lru_cache(maxsize=None)
def _no_effect(components: tuple[str, ...], cls: type | None) -> tuple[tuple[str, str], ...]:
    have = accepted_names(cls)
    out: dict[str, str] = {}
    for comp in components:
        renamed = DEPRECATED.get(comp, {})
        current_of = {new: old for old, new in renamed.items()}
        for key in sorted(COMPONENTS[comp] - have):
            if key in out:
                continue
            if key in renamed and renamed[key] in have:
                out[key] = f"no effect (deprecated name of {renamed[key]!r}; zenav reads only {renamed[key]!r})"
            elif key in current_of and current_of[key] in have:
                out[key] = f"no effect (zenav reads the deprecated name {current_of[key]!r} instead)"
            else:
                out[key] = "no effect (not implemented in zenav)"
    for key in sorted(ALL_KEYS - have - set(out)):
        out[key] = other_component_reason(key, components)
    return tuple(out.items())


def no_effect_keys(component: str | Iterable[str], cls: type | None = None) -> dict[str, str]:
    """key -> why for every catalogued key that ``cls`` (the zenav params dataclass of ``component``)
    does not read: the component's own keys ("no effect (not implemented in zenav)") and every other
    component's ("no effect here (a <component> parameter)"). Pass it to ``load_params(no_effect=...)``.
    ``component`` may be several (e.g. a costmap namespace is costmap_2d and nav2_costmap_2d)."""
    comps = (component,) if isinstance(component, str) else tuple(component)
    for c in comps:
        if c not in COMPONENTS:
            raise KeyError(f"unknown ROS component {c!r}; known: {sorted(COMPONENTS)}")
    return dict(_no_effect(comps, cls))


def load_ros_params(cls: type, mapping: Mapping | None, source: str, section: str,
                    component: str | Iterable[str], notes: list[str] | None = None,
                    ignore: Iterable[str] = (), extra: Mapping[str, str] | None = None) -> Any:
    """``load_params`` for the namespace of a ROS component: every problem of ``mapping`` in one
    ConfigError; ROS keys without effect appended to ``notes`` (``source: section.key: why``).
    ``ignore``: keys read elsewhere (sub-namespaces); ``extra``: more key -> why, e.g. context-specific."""
    no_effect = no_effect_keys(component, cls)
    comps = (component,) if isinstance(component, str) else tuple(component)
    for comp in comps:
        for wrong, right in MISSPELT.get(comp, {}).items():
            no_effect.setdefault(wrong, f"no effect (ROS only warns about it: the parameter is {right!r})")
    for key in mapping or {}:  # "point_grid/max_sensor_range": a key inside a namespace ROS knows
        head = str(key).split("/")[0]
        if "/" in str(key) and head in no_effect and str(key) not in accepted_names(cls):
            no_effect.setdefault(str(key), no_effect[head])
    no_effect.update(extra or {})
    return load_params(cls, dict(mapping or {}), source=source, section=section, ignore=tuple(ignore),
                       no_effect=no_effect, notes=notes)
