"""AMCL's ``omni`` odometry model (ROS amcl_odom.cpp, ODOM_MODEL_OMNI): the increment moves every particle in
its own frame, and a turn spreads the particles sideways, which the ``diff`` model never does."""

from __future__ import annotations

import math

import numpy as np
import pytest

from common.config import ConfigError
from common.geometry import Pose2D, pivoted
from master_side.localization.amcl import Amcl
from master_side.localization.motion_model import DiffMotionModel, OmniMotionModel
from master_side.localization.params import load_amcl_params
from tests.amcl.amcl_support import box_map


def test_the_increment_moves_each_particle_in_its_own_frame():
    model = OmniMotionModel(0.0, 0.0, 0.0, 0.0, 0.0)
    old, new = Pose2D(1.0, 1.0, 0.0), Pose2D(1.3, 1.4, 0.5)  # forward 0.3, left 0.4, a turn of 0.5
    out = model.sample(np.array([[0.0, 0.0, math.pi / 2]]), old, new, np.random.default_rng(0))
    moved = Pose2D(0.0, 0.0, math.pi / 2).compose(Pose2D(0.3, 0.4, 0.5))
    np.testing.assert_allclose(out[0], moved.as_array(), atol=1e-12)


@pytest.mark.parametrize("corrected", [False, True])
def test_a_turn_in_place_spreads_the_particles_sideways_as_alpha1_says(corrected):
    """A skid-steered base moves sideways while it turns and its odometry cannot see it: with ``omni`` the
    particles after an in-place turn spread sideways by alpha1 * rot^2 (its square root, corrected); with
    ``diff`` an in-place turn moves particles along their heading only, never sideways."""
    rot, a1, n = 0.3, 0.2, 20000
    old, new = Pose2D(0.0, 0.0, 0.0), Pose2D(0.0, 0.0, rot)
    start = np.zeros((n, 3))
    omni = OmniMotionModel(a1, 0.0, 0.0, 0.0, 0.0, corrected).sample(start, old, new, np.random.default_rng(1))
    want = a1 * rot * rot
    want = math.sqrt(want) if corrected else want
    assert np.std(omni[:, 1]) == pytest.approx(want, rel=0.05)  # sideways: the strafe noise
    assert np.std(omni[:, 0]) == pytest.approx(want, rel=0.05)  # along the bearing: translation noise
    diff = DiffMotionModel(a1, 0.0, 0.0, a1, corrected).sample(start, old, new, np.random.default_rng(1))
    assert np.abs(diff[:, 1]).max() == 0.0 and np.std(diff[:, 0]) > 0.0  # heading 0: x is along it


def test_omni_and_alpha5_are_amcl_parameters():
    p = load_amcl_params({"odom_model_type": "omni-corrected", "odom_alpha5": 0.05}, "amcl.yaml")
    assert (p.odom_model_type, p.odom_alpha5) == ("omni-corrected", 0.05)
    with pytest.raises(ConfigError, match="odom_model_type"):
        load_amcl_params({"odom_model_type": "tricycle"}, "amcl.yaml")


def test_amcl_counts_the_sideways_increments_the_diff_model_misreads():
    """Odometry of a base that turns about a point off base_link (robot_side's ``odom_rotation_center_x``)
    moves base_link sideways as it turns. ROS's diff model reads that as a turn, a drive and a turn back,
    with both turns' noise; AMCL counts such increments (the node warns at the first) and the omni models,
    which take them as they are, do not. A diff drive's own arcs, forward or backward, are not counted."""
    c, a = -0.12, 0.5
    old = Pose2D(0.5, -0.3, 0.4)
    pivot = old.compose(pivoted(Pose2D(0.0, 0.0, a), c))
    counts = {}
    for model in ("diff", "omni"):
        amcl = Amcl(load_amcl_params({"odom_model_type": model, "seed": 1}, "amcl.yaml"), box_map())
        assert not amcl._sideways(old, old.compose(Pose2D(0.3 * math.sin(a) / a, 0.3 * (1 - math.cos(a)) / a, a)))
        assert not amcl._sideways(old, old.compose(Pose2D(-0.2, 0.0, 0.0)))  # backing up
        counts[model] = amcl._sideways(old, pivot)
        # a drive and a 1.6 rad turn in one increment (scans dropped): either order is possible, not judged
        assert not amcl._sideways(old, old.compose(Pose2D(0.05, 0.0, 0.0)).compose(Pose2D(0.0, 0.0, 1.6)))
    assert counts == {"diff": True, "omni": False}
    with pytest.raises(ConfigError, match="odom_rotation_center_x"):  # moved to the robot's odometry
        load_amcl_params({"odom_model_type": "omni", "odom_rotation_center_x": c}, "amcl.yaml")
