import numpy as np
import pytest

from common.config import ConfigError
from common.messages import LaserScan, Twist, msg_equal
from robot_side.sim.simulator import Pacer, Simulator


def _sim(**over):
    cfg = {"world": "room", "sim": {"seed": 1}, "laser": {"model": "hokuyo_urg04lx"},
           "depth_camera": {"depth_mode": 8, "data_skip": 1}, **over}
    return Simulator.from_config(cfg, "test.yaml")


def test_sensors_are_due_at_their_rates():
    sim = _sim()
    stamps = {"laser": [], "depth_camera": []}
    while sim.time < 2.0 - 1e-9:
        for name in sim.step():
            stamps[name].append(sim.time)
    assert sim.time == pytest.approx(2.0)
    assert len(stamps["laser"]) == 20  # URG-04LX: 10 Hz
    assert len(stamps["depth_camera"]) == pytest.approx(30, abs=1)  # 30 Hz, data_skip 1: every 2nd
    # on the rate's grid from the first reading on (t = 0 precedes the first step: no reading at dt)
    assert np.allclose(stamps["laser"], 0.1 * np.arange(1, 21))
    assert np.allclose(np.diff(stamps["depth_camera"]), 1 / 15, atol=0.011)
    assert stamps["depth_camera"][0] >= 1 / 15 - 1e-9


def test_same_seed_same_run_other_seed_differs():
    def run(seed):
        sim = _sim(sim={"seed": seed})
        scans = []
        for _ in range(150):
            sim.cmd_vel(Twist.planar(0.4, 0.2))
            if "laser" in sim.step():
                scans.append(sim.scan())
        return sim.odometry(), scans
    (o1, s1), (o2, s2), (o3, _) = run(5), run(5), run(6)
    assert msg_equal(o1, o2)
    assert all(msg_equal(a, b) for a, b in zip(s1, s2))
    assert not msg_equal(o1, o3)
    assert isinstance(s1[0], LaserScan)
    assert s1[0].header.stamp > 0


def test_outputs_and_frames():
    sim = _sim(start=[-1.0, 0.5, 0.0])
    assert sim.ground_truth.x == -1.0
    img, info = sim.depth_frame()
    assert img.depth.shape == (info.height, info.width) == (120, 160)
    assert img.header.frame_id == info.header.frame_id == "camera_depth_optical_frame"
    children = [t.child_frame_id for t in sim.static_transforms()]
    assert children == ["laser", "camera_link", "camera_depth_optical_frame"]
    sim.set_motors(False)
    assert not sim.motor_state().enabled
    assert sim.odom_transform().header.frame_id == "odom"
    assert sim.collision().count == 0


def test_sensor_can_be_left_out_and_bad_config_is_reported():
    sim = _sim(laser=None)
    assert sim.laser is None
    assert "laser" not in sim.step()
    with pytest.raises(ConfigError, match="test.yaml: colour"):
        _sim(colour=1)
    with pytest.raises(ConfigError, match="world"):
        _sim(world="no_such_world")
    with pytest.raises(ConfigError, match="base.max_vel_x"):
        _sim(base={"max_vel_x": -1})


def test_pacer_tracks_the_real_time_factor():
    p = Pacer(factor=4.0)
    assert p.steps_due(wall_elapsed=0.5, sim_time=1.0, dt=0.01) == 100
    assert p.steps_due(wall_elapsed=0.5, sim_time=2.5, dt=0.01) == 0
    assert np.isclose(Pacer(0.5).steps_due(1.0, 0.0, 0.1), 5)
