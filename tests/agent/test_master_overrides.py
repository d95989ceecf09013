"""`zenav master --map FILE --set NODE.KEY=VALUE`: one shipped file serves every world and start (the demo
runs the shipped files this way); the generated parameters keep the file's relative paths valid."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest

from common.config import ConfigError, read_yaml
from common.node_check import check_nodes
from deploy.stack.demo import master_args
from master_side import agent

CONFIG = Path(__file__).resolve().parents[2] / "master_side" / "config"


def _params(launch, name: str, tmp_path: Path) -> dict:
    spec = next(s for s in launch.specs(str(tmp_path / "gen")) if s.name == name)
    data = read_yaml(spec.config)
    for part in spec.section.split("."):
        data = data[part]
    return data


def test_map_and_set_override_a_shipped_file_and_keep_its_relative_paths(tmp_path):
    other_map = CONFIG / "maps" / "corridor.yaml"  # the file's own map is the room
    launch = agent.load(str(CONFIG / "p3at_amcl.yaml"), str(other_map),
                        ["localization.initial_pose_x=1.5",
                         f"move_base.local_planner={CONFIG / 'p3at' / 'dwa_planner_ros.yaml'}"])
    assert _params(launch, "map_server", tmp_path)["map"] == str(other_map)
    loc = _params(launch, "localization", tmp_path)
    assert loc["initial_pose_x"] == 1.5 and loc["max_particles"] == 3000  # the rest of the node's mapping kept
    mb = _params(launch, "move_base", tmp_path)
    assert mb["local_planner"] == str(CONFIG / "p3at" / "dwa_planner_ros.yaml")
    assert mb["move_base"] == str(CONFIG / "p3at" / "move_base.yaml")  # was p3at/move_base.yaml, relative
    check_nodes(launch)  # every node's check passes on the generated parameters
    wrong = agent.load(str(CONFIG / "p3at_amcl.yaml"), sets=["move_base.controller_frequency=4"])
    with pytest.raises(ConfigError, match="controller_frequency: unknown key"):  # it is move_base.yaml's
        check_nodes(wrong)


@pytest.mark.parametrize(("sets", "match"), [
    (["initial_pose_x=1"], "NODE.KEY=VALUE"),
    (["localization.initial_pose_x"], "NODE.KEY=VALUE"),
    (["amcl.initial_pose_x=1"], "no node 'amcl'"),
    (["localization.initial_pose_x=[1"], "not valid YAML"),
])
def test_a_bad_set_is_refused_with_the_reason(sets, match):
    with pytest.raises(ConfigError, match=match):
        agent.load(str(CONFIG / "p3at_amcl.yaml"), sets=sets)


def test_map_needs_a_map_server_and_an_existing_file(tmp_path):
    with pytest.raises(ConfigError, match="needs a map server"):
        agent.load(str(CONFIG / "p3at_slam.yaml"), str(CONFIG / "maps" / "room.yaml"))
    with pytest.raises(ConfigError, match="file not found"):
        agent.load(str(CONFIG / "p3at_known_map.yaml"), str(tmp_path / "missing.yaml"))


@pytest.mark.parametrize(("planner", "slam", "amcl"), [
    ("dwa", False, False), ("trajectory", False, False), ("dwa", False, True), ("trajectory", False, True),
    ("dwa", "gmapping", False), ("trajectory", "hector", False)])
def test_every_demo_mode_runs_a_shipped_file_that_passes_the_agents_check(tmp_path, planner, slam, amcl):
    p = argparse.ArgumentParser()
    agent.add_arguments(p)
    args = p.parse_args(master_args("corridor", planner, tmp_path, slam, amcl))
    assert Path(args.config).parent == CONFIG  # no generated master file
    launch = agent.load(args.config, args.map, args.set)
    check_nodes(launch)
    mb = _params(launch, "move_base", tmp_path)
    assert Path(mb["local_planner"]).name == ("dwa_planner_ros.yaml" if planner == "dwa"
                                              else "base_local_planner_params.yaml")
    if amcl:
        assert _params(launch, "localization", tmp_path)["initial_pose_x"] == pytest.approx(-4.0, abs=6)


def test_set_reads_numbers_and_files_as_the_node_will(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # nothing of the config's folder here
    launch = agent.load(str(CONFIG / "p3at_known_map.yaml"), str(CONFIG / "maps" / "corridor.yaml"),
                        ["move_base.local_planner=p3at_zenav/dwa_planner_ros.yaml"])
    mb = _params(launch, "move_base", tmp_path)
    assert mb["local_planner"] == str(CONFIG / "p3at_zenav" / "dwa_planner_ros.yaml")  # beside the config
    check_nodes(launch)
    amcl = agent.load(str(CONFIG / "p3at_amcl.yaml"), sets=["localization.initial_pose_a=1e-3",
                                                            "localization.odom_frame_id=p3at"])
    loc = _params(amcl, "localization", tmp_path)
    assert loc["initial_pose_a"] == 0.001  # YAML 1.1 alone would give the string '1e-3'
    assert loc["odom_frame_id"] == "p3at"  # a folder of that name beside the config is not a file


def test_robot_set_changes_a_nested_key_and_keeps_the_rest_of_its_section(tmp_path):
    """`zenav robot --set sim.base.odom_rotation_center_x=-0.12`: a key of the simulator's ``base`` mapping,
    the node's other parameters (its laser, its world) kept; a value out of range is refused at start with
    the key and its range, as in the file."""
    from robot_side import agent as robot_agent

    shipped = Path(__file__).resolve().parents[2] / "robot_side" / "config" / "p3at_sim_laser.yaml"
    launch = robot_agent.load(str(shipped), engine="mujoco",
                              sets=["sim.base.odom_rotation_center_x=-0.12", "sim.laser.rate=10"])
    sim = _params(launch, "sim", tmp_path)
    assert sim["base"] == {"odom_rotation_center_x": -0.12} and sim["engine"] == "mujoco"
    assert sim["laser"]["rate"] == 10 and sim["laser"]["samples"] == 361  # the section's other keys kept
    check_nodes(launch)
    bad = robot_agent.load(str(shipped), sets=["sim.base.odom_rotation_center_x=5"])
    with pytest.raises(ConfigError, match=r"odom_rotation_center_x.*\[-2"):
        check_nodes(bad)
    with pytest.raises(ConfigError, match="sim.world is 'room', not a mapping"):
        robot_agent.load(str(shipped), sets=["sim.world.size=3"])
    with pytest.raises(ConfigError, match="empty key"):
        robot_agent.load(str(shipped), sets=["sim..x=3"])
    # a sensor the file leaves out stays out: a nested --set does not create it
    no_laser = robot_agent.load(str(shipped), sets=["sim.laser=null"])
    with pytest.raises(ConfigError, match="sim.laser is None, not a mapping"):
        no_laser.set("sim.laser.rate=10")


def test_the_physics_sets_apply_to_the_shipped_files_and_nothing_changes_on_the_kinematic_engine(tmp_path):
    """deploy/stack/physics_sets.py: what zenav's configurations are told about the P3-AT on MuJoCo (the
    benches and `zenav demo --explore --engine mujoco` pass it). Each value must pass the nodes' checks on the
    shipped files, so a renamed parameter fails here and not 30 minutes into a benchmark."""
    from deploy.stack.physics_sets import PHYSICS_PIVOT_X, master_sets, robot_sets
    from master_side.move_base.config import load_move_base_config
    from robot_side import agent as robot_agent

    assert robot_sets("kinematic") == robot_sets(None) == () == master_sets("kinematic", amcl=True) \
        == master_sets("kinematic", amcl=False) == master_sets(None, amcl=False)
    robot = robot_agent.load(str(CONFIG.parent.parent / "robot_side" / "config" / "p3at_sim_laser.yaml"),
                             engine="mujoco", sets=robot_sets("mujoco"))
    check_nodes(robot)
    assert _params(robot, "sim", tmp_path)["base"]["odom_rotation_center_x"] == PHYSICS_PIVOT_X
    assert _params(robot, "collision_monitor", tmp_path)["rotation_center_x"] == PHYSICS_PIVOT_X
    for config, amcl, dwa in (("p3at_zenav.yaml", True, "dwa_planner_ros_mujoco.yaml"),
                              ("p3at_slam_zenav.yaml", False, "dwa_planner_ros_slam_mujoco.yaml")):
        launch = agent.load(str(CONFIG / config), sets=master_sets("mujoco", amcl))
        check_nodes(launch)
        assert Path(_params(launch, "move_base", tmp_path)["local_planner"]).name == dwa
        lp = load_move_base_config(*launch.node_params(launch.entry("move_base"))).local_params
        assert (lp.rotation_center_x, lp.min_vel_x) == (-0.12, -0.1 if amcl else 0.0)
    kinematic = agent.load(str(CONFIG / "p3at_slam_zenav.yaml"))  # the SLAM file's own DWA: forward only too
    assert load_move_base_config(*kinematic.node_params(kinematic.entry("move_base"))).local_params.min_vel_x == 0.0
    assert not any(kv.startswith("localization.") for kv in master_sets("mujoco", amcl=False))  # SLAM: no AMCL
