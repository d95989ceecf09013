import numpy as np
from costmap_helpers import inflation_layer, layered, obstacle_layer, voxel_layer

from common.geometry import Pose2D
from master_side.costmap.cost_values import FREE, LETHAL


def test_rolling_window_shifted_by_non_integer_cells_keeps_obstacles_at_the_same_world_position():
    lc = layered(3.0, 0.025, rolling=True)
    ob = obstacle_layer(lc, clearing=False)
    inflation_layer(lc, radius=0.3, factor=5.0)
    obstacle = (0.8123, 0.4567)
    pose = Pose2D(0.0, 0.0, 0.0)
    ob.add_observation("scan", np.array([[*obstacle, 0.2]]), np.array([0.0, 0.0, 0.2]), 0.0)
    lc.update_map(pose)
    assert lc.master.get_cost(*obstacle) == LETHAL
    ob.buffers["scan"].clear()
    origin0 = (lc.master.origin_x, lc.master.origin_y)
    for _ in range(7):  # 0.337 / 0.025 = 13.48 cells per step
        pose = Pose2D(pose.x + 0.0337 * 10, pose.y - 0.0219 * 10, 0.0)
        lc.update_map(pose)
        if abs(obstacle[0] - pose.x) < 1.4 and abs(obstacle[1] - pose.y) < 1.4:
            assert lc.master.get_cost(*obstacle) == LETHAL
            assert lc.master.get_cost(obstacle[0] + 0.1, obstacle[1]) not in (FREE, LETHAL)  # inflated
        # the origin stays on the lattice of the original grid, within one cell of centring the robot
        steps = (np.array([lc.master.origin_x, lc.master.origin_y]) - origin0) / 0.025
        np.testing.assert_allclose(steps, np.round(steps), atol=1e-6)
        assert abs(lc.master.origin_x + 1.5 - pose.x) < 0.025
    assert (lc.master.data == LETHAL).sum() == 0  # the obstacle has left the window by now


def test_rolling_window_moves_back_and_forth_without_smearing():
    lc = layered(3.0, 0.05, rolling=True)
    ob = obstacle_layer(lc, clearing=False)
    ob.add_observation("scan", np.array([[0.52, 0.31, 0.2]]), np.array([0.0, 0.0, 0.2]), 0.0)
    lc.update_map(Pose2D())
    ob.buffers["scan"].clear()
    for x in (0.23, 0.61, -0.44, 0.0):
        lc.update_map(Pose2D(x, 0.17, 0.0))
        assert (lc.master.data == LETHAL).sum() == 1
        assert lc.master.get_cost(0.52, 0.31) == LETHAL


def test_voxel_grid_rolls_with_the_window():
    lc = layered(3.0, 0.05, rolling=True)
    vx = voxel_layer(lc, z_voxels=4, z_resolution=0.5)
    vx.add_observation("cloud", np.array([[0.52, 0.31, 0.7]]), np.array([0.0, 0.0, 0.7]), 0.0)
    lc.update_map(Pose2D())
    vx.buffers["cloud"].clear()
    lc.update_map(Pose2D(0.377, -0.2, 0.0))
    mx, my, ok = lc.master.world_to_map(0.52, 0.31)
    assert ok
    assert vx.voxels()[0][1, my, mx]
    assert lc.master.get_cost(0.52, 0.31) == LETHAL
