import numpy as np

from common.geometry import Pose2D
from master_side.slam.grid import TiledGrid, unique_tile_bytes
from master_side.slam.gridslam import integrate, prepare_beams
from master_side.slam.params import GMappingParams

P = GMappingParams(maxUrange=20.0, maxRange=25.0)


def _mapped(room_scan) -> TiledGrid:
    g = TiledGrid(P.delta)
    win = g.window(-6, -5, 6, 5)
    g.store(win, integrate(win, np.zeros(3), prepare_beams(room_scan(Pose2D()), P, Pose2D())))
    return g


def test_copies_share_tiles_until_written(room_scan):
    g = _mapped(room_scan)
    copies = [g.copy() for _ in range(50)]
    assert unique_tile_bytes([g, *copies]) == g.memory_bytes()
    win = copies[0].window(0, 0, 1, 1)
    win.data[:] = 3.0
    copies[0].store(win, np.arange(win.data.size))
    assert unique_tile_bytes([g, *copies]) == g.memory_bytes() + win.data.nbytes
    assert not np.array_equal(g.window(0, 0, 1, 1).data, copies[0].window(0, 0, 1, 1).data)
    assert np.array_equal(g.window(0, 0, 1, 1).data, copies[1].window(0, 0, 1, 1).data)


def test_reused_window_buffers_hold_the_grids_data(room_scan):
    """A buffer refilled with ``seen`` skips the tiles it already holds; after integrating, storing,
    copying (the written grid clones shared tiles) and switching grids it equals a fresh window."""
    rng = np.random.default_rng(3)
    grids = [_mapped(room_scan)]
    grids.append(grids[0].copy())
    bufs = [(np.empty(0, np.float32), None), (np.empty(0, np.float32), None)]
    box = (-6, -5, 6, 5)
    for step in range(8):
        order = [step % 2, 1 - step % 2]  # buffers change grids, as after resampling
        wins = [grids[g].window(*box, out=bufs[b][0], seen=bufs[b][1]) for b, g in enumerate(order)]
        for b, g in enumerate(order):
            assert np.array_equal(wins[b].data, grids[g].window(*box).data)
        pose = np.array([*rng.normal(0, 0.5, 2), rng.uniform(-3, 3)])
        beams = prepare_beams(room_scan(Pose2D(*pose)), P, Pose2D())
        grids[order[0]].store(wins[0], integrate(wins[0], pose, beams))  # the other window: not integrated
        if step % 3 == 0:
            grids[order[1]] = grids[order[0]].copy()
        bufs = [(w.data.base, w.seen) for w in wins]


def test_occupancy_grid_marks_walls_free_space_and_unknown(room_scan):
    og = _mapped(room_scan).to_occupancy_grid()
    res, o = og.resolution, og.origin

    def cell(x, y):
        return og.data[int((y - o.y) / res), int((x - o.x) / res)]

    assert cell(0.0, 0.0) == 0
    assert cell(4.01, 0.0) == 100
    assert cell(5.5, 0.0) == -1
