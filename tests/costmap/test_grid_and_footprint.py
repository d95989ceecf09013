import math

import numpy as np
import pytest
from costmap_helpers import layered

from common.geometry import Pose2D, footprint_radii
from common.messages import Header, OccupancyGrid
from master_side.costmap.cost_values import FREE, LETHAL, NO_INFORMATION
from master_side.costmap.costmap2d import (
    Costmap2D,
    Window,
    update_with_max,
    update_with_overwrite,
    update_with_true_overwrite,
)
from master_side.costmap.footprint import (
    footprint_from_params,
    parse_footprint,
    transform_footprint,
)
from master_side.costmap.layer import Layer, register_layer
from master_side.costmap.layer_params import StaticLayerParams
from master_side.costmap.static_layer import StaticLayer


def test_world_map_conversions_are_vectorised_and_consistent():
    cm = Costmap2D(10, 5, 0.5, -1.0, 2.0)
    mx, my, ok = cm.world_to_map(np.array([-1.0, -0.76, 3.99, 4.0]), np.array([2.0, 2.3, 4.49, 2.0]))
    assert list(mx) == [0, 0, 9, 10]
    assert list(my) == [0, 0, 4, 0]
    assert list(ok) == [True, True, True, False]
    wx, wy = cm.map_to_world(mx[:3], my[:3])
    assert list(cm.world_to_map(wx, wy)[0]) == list(mx[:3])


def test_combination_rules_follow_costmap_2d():
    master = Costmap2D(3, 1, 1.0)
    master.data[0] = [NO_INFORMATION, 100, 100]
    layer = np.array([[50, NO_INFORMATION, 200]], np.uint8)
    w = master.full_window()
    update_with_max(master, layer, w)
    assert list(master.data[0]) == [50, 100, 200]
    master.data[0] = [NO_INFORMATION, 100, 100]
    update_with_overwrite(master, layer, w)
    assert list(master.data[0]) == [50, 100, 200]
    update_with_true_overwrite(master, layer, Window(1, 0, 2, 1))
    assert list(master.data[0]) == [50, NO_INFORMATION, 200]


def test_footprint_string_parsing_padding_and_radii():
    fp = parse_footprint("[[0.3, -0.2], [0.3, 0.2], [-0.3, 0.2], [-0.3, -0.2]]")
    assert fp.shape == (4, 2)
    padded = footprint_from_params(fp.tolist(), 0.46, 0.05)
    assert padded[0].tolist() == pytest.approx([0.35, -0.25])
    inscribed, circumscribed = footprint_radii(padded)
    assert inscribed == pytest.approx(0.25)
    assert circumscribed == pytest.approx(math.hypot(0.35, 0.25))
    circle = footprint_from_params("[]", 0.5, 0.0)
    assert len(circle) == 16
    assert footprint_radii(circle)[1] == pytest.approx(0.5)
    moved = transform_footprint(fp, Pose2D(1.0, 2.0, math.pi / 2))
    assert moved[0].tolist() == pytest.approx([1.2, 2.3])
    with pytest.raises(ValueError, match="at least 3"):
        parse_footprint([[0, 0], [1, 0]])


def test_layer_registry_refuses_duplicate_type_names():
    with pytest.raises(ValueError, match="registered twice"):
        register_layer("costmap_2d::InflationLayer")(type("Other", (Layer,), {}))


def test_static_layer_interprets_occupancy_as_ros_does_and_sizes_the_master():
    data = np.array([[0, 50, 99], [100, -1, 65]], np.int8)
    grid = OccupancyGrid(Header(0.0, "map"), 0.5, Pose2D(-1.0, -1.0, 0.0), data)
    lc = layered(4.0, 0.1)
    st = lc.add_layer(StaticLayer("static", StaticLayerParams(lethal_cost_threshold=65)))
    st.set_map(grid)
    lc.update_map(Pose2D())
    assert lc.master.data.shape == (2, 3)
    assert lc.master.resolution == 0.5
    assert lc.master.data.tolist() == [[FREE, FREE, LETHAL], [LETHAL, NO_INFORMATION, LETHAL]]


def test_static_layer_in_a_rolling_window_copies_the_map_under_the_window():
    data = np.zeros((40, 40), np.int8)
    data[20, 25] = 100
    grid = OccupancyGrid(Header(0.0, "map"), 0.1, Pose2D(0.0, 0.0, 0.0), data)
    lc = layered(1.0, 0.05, rolling=True)
    st = lc.add_layer(StaticLayer("static", StaticLayerParams()))
    st.set_map(grid, map_to_global=Pose2D(1.0, 0.0, 0.0))  # the map frame is 1 m ahead in odom
    lc.update_map(Pose2D(3.3, 2.0, 0.0))
    assert lc.master.data.shape == (20, 20)
    assert lc.master.get_cost(3.55, 2.05) == LETHAL  # map cell (25, 20) = (2.55, 2.05) in map frame
    assert lc.master.get_cost(3.3, 2.0) == FREE


def test_a_rolling_static_layer_follows_its_map_frame_when_placed_again():
    """Localisation moves map against odom: the walls in a local costmap move with it (ROS's StaticLayer
    looks map -> global_frame up in every update; the node and the in-process stack call ``place``)."""
    data = np.zeros((40, 40), np.int8)
    data[20, 25] = 100  # (2.55, 2.05) in the map frame
    grid = OccupancyGrid(Header(0.0, "map"), 0.1, Pose2D(0.0, 0.0, 0.0), data)
    lc = layered(1.0, 0.05, rolling=True)
    st = lc.add_layer(StaticLayer("static", StaticLayerParams()))
    st.set_map(grid, map_to_global=Pose2D(1.0, 0.0, 0.0))
    lc.update_map(Pose2D(3.3, 2.0, 0.0))
    assert lc.master.get_cost(3.55, 2.05) == LETHAL
    st.place(Pose2D(0.8, 0.0, 0.0))  # odometry drifted 0.2 m: map is now 0.8 m ahead in odom
    lc.update_map(Pose2D(3.3, 2.0, 0.0))
    assert lc.master.get_cost(3.35, 2.05) == LETHAL
    assert lc.master.get_cost(3.55, 2.05) == FREE
