"""hector_mapping's parameter files, the master config and `zenav demo --slam [hector]`."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest

from common.config import ConfigError, read_yaml
from deploy.cli import demo as cmd_demo
from deploy.stack.demo import master_args
from master_side import agent
from master_side.hector import node

CONFIG = Path(__file__).resolve().parents[2] / "master_side" / "config"


def test_the_p3at_master_config_loads_hector_with_its_parameter_file():
    src = CONFIG / "p3at_hector.yaml"
    cfg = read_yaml(src)["nodes"]["hector_mapping"]
    assert cfg["module"] == "master_side.hector.node"
    notes = [str(n) for n in node.check(cfg["params"], str(src))]
    assert any("laser_z_min_value" in n for n in notes)  # accepted, reported as without effect


def test_hector_rejects_unknown_and_out_of_range_parameters_at_once():
    with pytest.raises(ConfigError) as e:
        node.check({"map_resolutoin": 0.05, "update_factor_free": 0.7}, "x.yaml")
    text = str(e.value)
    assert "map_resolution" in text and "update_factor_free" in text  # did-you-mean + range


def test_demo_slam_flag_defaults_to_gmapping_and_accepts_hector(tmp_path):
    p = argparse.ArgumentParser()
    cmd_demo.add_parser(p.add_subparsers())
    assert p.parse_args(["demo", "--slam"]).slam == "gmapping"
    assert p.parse_args(["demo", "--slam", "hector"]).slam == "hector"
    assert p.parse_args(["demo"]).slam is None
    args = master_args("room", "dwa", tmp_path, slam="hector")
    assert args == ["--config", str(CONFIG / "p3at_hector.yaml")]  # the shipped file, as it is
    nodes = {e.name for e in agent.load(args[1]).entries}
    assert "hector_mapping" in nodes and "slam_gmapping" not in nodes and "map_server" not in nodes
    assert master_args("room", "dwa", tmp_path, slam=True) == ["--config", str(CONFIG / "p3at_slam.yaml")]


def test_demo_runs_hector_on_the_planar_laser_and_gmapping_on_the_kinect():
    from deploy.stack.demo import ROBOT_CONFIG, robot_config

    assert robot_config("hector").name == "p3at_sim_laser.yaml"
    assert robot_config(True) == robot_config("gmapping") == robot_config(False) == ROBOT_CONFIG
    laser = read_yaml(robot_config("hector"))["platform"]["sim"]["params"]["laser"]
    assert laser["angle_max"] - laser["angle_min"] > 3.0  # a wide planar scan, hector's sensor
