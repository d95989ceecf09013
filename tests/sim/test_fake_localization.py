"""fake_localization pairs ground truth and odometry of the same simulator step, whatever the skew
between its two inputs' delivery threads (each subscription has its own queue of 100 and thread)."""

from __future__ import annotations

import pytest

from common.config import ConfigError
from common.geometry import Pose2D
from common.messages import Header, Odometry
from robot_side.sim.fake_localization import FakeLocalizationParams, StepPairer, check, map_to_odom


def _odom(t: float, frame: str, pose: Pose2D) -> Odometry:
    return Odometry(header=Header(t, frame), pose=pose.to_transform())


def test_every_step_is_paired_when_one_input_runs_a_whole_queue_behind():
    pairs = StepPairer()
    steps = [1000.0 + 0.01 * i for i in range(100)]
    out = []
    for i, t in enumerate(steps):  # ground truth delivered first, a whole queue (100) ahead of odometry
        out.append(pairs.add("truth", _odom(t, "map", Pose2D(1.0 + i * 0.01, 2.0, 0.3))))
    for i, t in enumerate(steps):
        out.append(pairs.add("odom", _odom(t, "odom", Pose2D(i * 0.01, 0.0, 0.0))))
    done = [p for p in out if p is not None]
    assert len(done) == 100  # with 20 kept (before): the last 20, and none while a stream stays skewed
    truth, odom = done[-1]
    assert truth.header.stamp == odom.header.stamp == steps[-1]
    tf = map_to_odom(truth, odom)
    assert (tf.header.frame_id, tf.child_frame_id) == ("map", "odom")
    p, want = tf.transform.to_pose2d(), truth.pose2d.compose(odom.pose2d.inverse())
    assert abs(p.x - want.x) < 1e-9 and abs(p.y - want.y) < 1e-9 and abs(p.theta - want.theta) < 1e-9


def test_old_unmatched_steps_are_dropped():
    pairs = StepPairer(keep=5)
    for i in range(10):
        assert pairs.add("truth", _odom(float(i), "map", Pose2D())) is None
    assert sorted(pairs.pending["truth"]) == [round(i * 1e4) for i in range(5, 10)]
    assert pairs.add("odom", _odom(2.0, "odom", Pose2D())) is None  # its partner was dropped
    assert pairs.add("odom", _odom(7.0, "odom", Pose2D())) is not None


def test_map_to_odom_is_future_dated_by_transform_tolerance_as_ros_does():
    truth, odom = _odom(5.0, "map", Pose2D(1.0, 0.0, 0.0)), _odom(5.0, "odom", Pose2D())
    assert FakeLocalizationParams().transform_tolerance == 0.1  # ROS fake_localization's default
    assert map_to_odom(truth, odom, 0.1).header.stamp == 5.1
    assert check({"transform_tolerance": 0.2}, "f.yaml") == []


def test_a_bad_transform_tolerance_names_the_file_key_and_range():
    with pytest.raises(ConfigError) as e:
        check({"transform_tolerance": -1.0}, "master.yaml")
    assert "master.yaml" in str(e.value) and "transform_tolerance" in str(e.value) and "[0.0, 10.0]" in str(e.value)
    with pytest.raises(ConfigError) as e:
        check({"transform_tolerence": 0.1}, "master.yaml")
    assert "transform_tolerance" in str(e.value)  # did you mean
