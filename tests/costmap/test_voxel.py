import numpy as np
from costmap_helpers import layered, voxel_layer

from common.geometry import Pose2D
from master_side.costmap.cost_values import FREE, LETHAL, NO_INFORMATION


def test_voxel_layer_marks_the_voxel_of_a_point_and_makes_its_column_lethal():
    lc = layered(4.0, 0.1)
    vx = voxel_layer(lc, z_voxels=8, z_resolution=0.25)
    vx.add_observation("cloud", np.array([[2.05, 2.05, 1.1]]), np.array([0.55, 2.05, 1.1]), 0.0)
    lc.update_map(Pose2D(0.55, 2.05, 0.0))
    marked, unknown = vx.voxels()
    assert marked[4, 20, 20]
    assert marked.sum() == 1
    assert not unknown[4, 20, 20]
    assert not unknown[4, 20, 10]
    assert unknown[0, 20, 10]  # other heights along the ray stay unknown
    assert lc.master.data[20, 20] == LETHAL
    assert lc.master.data[20, 10] == FREE


def test_voxel_clearing_is_3d_a_ray_above_an_obstacle_does_not_clear_it():
    lc = layered(4.0, 0.1)
    vx = voxel_layer(lc, z_voxels=8, z_resolution=0.25)
    origin = np.array([0.55, 2.05, 0.6])
    vx.add_observation("cloud", np.array([[2.05, 2.05, 0.6]]), origin, 0.0)  # obstacle at z level 2
    lc.update_map(Pose2D(0.55, 2.05, 0.0))
    assert lc.master.data[20, 20] == LETHAL
    high = np.array([0.55, 2.05, 1.85])
    vx.add_observation("cloud", np.array([[3.55, 2.05, 1.85]]), high, 1.0)  # passes over it at z level 7
    lc.update_map(Pose2D(0.55, 2.05, 0.0))
    assert lc.master.data[20, 20] == LETHAL
    vx.add_observation("cloud", np.array([[3.55, 2.05, 0.6]]), origin, 2.0)  # passes through it
    lc.update_map(Pose2D(0.55, 2.05, 0.0))
    assert lc.master.data[20, 20] == FREE
    assert lc.master.data[20, 35] == LETHAL


def test_mark_threshold_needs_more_marked_voxels_in_the_column():
    lc = layered(4.0, 0.1)
    vx = voxel_layer(lc, z_voxels=8, z_resolution=0.25, mark_threshold=1)
    o = np.array([0.55, 2.05, 0.1])
    vx.add_observation("cloud", np.array([[2.05, 2.05, 0.1]]), o, 0.0)
    lc.update_map(Pose2D(0.55, 2.05, 0.0))
    assert lc.master.data[20, 20] != LETHAL
    vx.add_observation("cloud", np.array([[2.05, 2.05, 0.1], [2.05, 2.05, 0.4]]), o, 1.0)
    lc.update_map(Pose2D(0.55, 2.05, 0.0))
    assert lc.master.data[20, 20] == LETHAL


def test_cleared_column_with_many_unknown_voxels_stays_unknown():
    lc = layered(4.0, 0.1, track_unknown=True)
    vx = voxel_layer(lc, z_voxels=8, z_resolution=0.25, unknown_threshold=4, track_unknown=True)
    vx.add_observation("cloud", np.array([[3.05, 2.05, 0.6]]), np.array([0.55, 2.05, 0.6]), 0.0)
    lc.update_map(Pose2D(0.55, 2.05, 0.0))
    # one voxel of 8 cleared per column -> 7 unknown > 4: the column stays NO_INFORMATION
    assert lc.master.data[20, 15] == NO_INFORMATION
    assert lc.master.data[20, 30] == LETHAL
