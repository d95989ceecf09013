"""static_transform_publisher arguments: both ROS forms, `pi` expressions, the p3at file."""

from __future__ import annotations

import math

import numpy as np
import pytest
from tf_analytic import rot_x, rot_y, rot_z

from common.config import ConfigError, read_yaml
from common.static_tf_node import load_static_transforms
from common.tf import eval_number, parse_static_args


def test_p3at_static_transforms_yaml_loads_unchanged(shared_dir):
    path = shared_dir / "reference" / "p3at" / "static_transforms.yaml"
    cfg = read_yaml(path)
    assert cfg["Pioneer3AT_laserscan_tf"]["args"] == "0.1 0 0.35 0 pi/2 pi/2 base_link camera_link 100"
    (ts,) = load_static_transforms(cfg, str(path))
    assert (ts.header.frame_id, ts.child_frame_id) == ("base_link", "camera_link")
    t, q = ts.transform.translation, ts.transform.rotation
    assert (t.x, t.y, t.z) == (0.1, 0.0, 0.35)
    # yaw 0, pitch pi/2, roll pi/2 (fixed axes: R = Rz(yaw) Ry(pitch) Rx(roll)) as a quaternion:
    # q = qz(0) * qy(pi/2) * qx(pi/2) = (0.5, 0.5, -0.5, 0.5)
    np.testing.assert_allclose(q.as_array(), [0.5, 0.5, -0.5, 0.5], atol=1e-12)
    want = rot_z(0.0) @ rot_y(math.pi / 2) @ rot_x(math.pi / 2)
    np.testing.assert_allclose(q.as_matrix(), want, atol=1e-12)
    # By hand: columns are camera_link's axes in base_link — x down, y forward, z to the right.
    np.testing.assert_allclose(want, [[0, 1, 0], [0, 0, -1], [-1, 0, 0]], atol=1e-12)


def test_yaw_pitch_roll_form_with_and_without_period():
    ts, period = parse_static_args("1 2 3 0.3 -0.2 0.1 odom base_link 50")
    assert period == pytest.approx(0.05)
    np.testing.assert_allclose(ts.transform.rotation.as_matrix(), rot_z(0.3) @ rot_y(-0.2) @ rot_x(0.1),
                               atol=1e-12)
    ts2, period2 = parse_static_args(["1", "2", "3", "0.3", "-0.2", "0.1", "/odom", "/base_link"])
    assert period2 is None
    assert ts2 == ts


def test_quaternion_form_with_and_without_period():
    s = math.sqrt(0.5)
    ts, period = parse_static_args(f"1 0 0 0 0 {s} {s} map odom 100")
    assert period == pytest.approx(0.1)
    assert ts.transform.rotation.yaw == pytest.approx(math.pi / 2)
    ts2, period2 = parse_static_args("1 0 0 0 0 2 2 map odom")  # tf2 form; normalised
    assert period2 is None
    np.testing.assert_allclose(ts2.transform.rotation.as_array(), [0, 0, s, s], atol=1e-12)
    assert (ts2.header.frame_id, ts2.child_frame_id) == ("map", "odom")


@pytest.mark.parametrize(("text", "value"), [
    ("pi/2", math.pi / 2), ("-pi", -math.pi), ("-0.5*pi", -math.pi / 2), ("(1+1)/4", 0.5),
    ("1e-3", 0.001), ("2*pi/3", 2 * math.pi / 3), ("7", 7.0), ("+0.25", 0.25),
])
def test_numbers_may_be_simple_pi_expressions(text, value):
    assert eval_number(text) == pytest.approx(value)


@pytest.mark.parametrize("text", [
    "__import__('os').system('true')", "pi**2", "abs(-1)", "x", "1/0", "'1'", "[1]", "", "1e999", "True",
])
def test_anything_else_is_rejected_without_eval(text):
    with pytest.raises(ValueError):
        eval_number(text)


@pytest.mark.parametrize(("args", "why"), [
    ("0 0 0 0 0 0 base", "arguments"),
    ("0 0 0 0 0 0 0 0 0 0 0", "arguments"),
    ("0 0 0 0 0 0 a a", "different frame"),
    ("0 0 0 0 0 0 0 0 map odom", "zero length"),
    ("0 0 0 zero 0 0 map odom", "yaw"),
    ("0 0 0 0 0 0 map odom -5", "period"),
])
def test_bad_arguments_say_why(args, why):
    with pytest.raises(ValueError, match=why):
        parse_static_args(args)


def test_config_errors_name_the_key():
    with pytest.raises(ConfigError, match="f.yaml: cam.args: argument pitch"):
        load_static_transforms({"cam": {"args": "0 0 0 0 nope 0 a b"}}, "f.yaml")
    with pytest.raises(ConfigError, match="f.yaml: cam: expected a mapping with only the key 'args'"):
        load_static_transforms({"cam": {"argz": "0 0 0 0 0 0 a b"}}, "f.yaml")
    with pytest.raises(ConfigError, match="already has a static parent"):
        load_static_transforms({"a": {"args": "0 0 0 0 0 0 p c"}, "b": {"args": "0 0 0 0 0 0 q c"}}, "f.yaml")
    (one,) = load_static_transforms({"args": "0 0 1 0 0 0 base_link laser"})
    assert one.transform.translation.z == 1.0
