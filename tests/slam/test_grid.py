import numpy as np

from common.geometry import Pose2D
from master_side.slam.grid import TiledGrid, unique_tile_bytes
from master_side.slam.gridslam import integrate, integrate_flips, integrate_into, prepare_beams
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


def test_integrating_into_tiles_equals_a_window_stored_back(room_scan):
    """The filter writes scans straight into the shared tiles; the same scans through a dense window
    and ``store`` give the same log-odds, copies stay untouched by their source's writes (and the
    reverse), and unreferenced tiles go back to the pool."""
    rng = np.random.default_rng(3)
    box = (-6, -5, 6, 5)
    direct, stored = _mapped(room_scan), _mapped(room_scan)
    copies: list[tuple[TiledGrid, TiledGrid, np.ndarray]] = []
    for step in range(9):
        pose = np.array([*rng.normal(0, 0.5, 2), rng.uniform(-3, 3)])
        if step == 8:
            pose[:2] += 4.0  # beams off the range
        beams = prepare_beams(room_scan(Pose2D(*pose)), P, Pose2D(0.1, 0.0, 0.05))
        flips = integrate_into(direct, direct.tile_range(*box), pose, beams)
        win = stored.window(*box)
        touched, flipped = integrate_flips(win, pose, beams)
        stored.store(win, touched, flipped)
        assert flips == len(flipped)
        assert np.array_equal(direct.window(*box).data, stored.window(*box).data)
        for a, b, before in copies:
            assert np.array_equal(a.window(*box).data, before) and np.array_equal(b.window(*box).data, before)
        if step % 3 == 0:
            copies.append((direct.copy(), stored.copy(), direct.window(*box).data))
    assert unique_tile_bytes([direct, *[c[0] for c in copies]]) > direct.memory_bytes()
    pool = direct.pool
    free = pool.nfree
    del copies
    assert pool.nfree > free  # the copies' own tiles are free again
    assert (pool.refs[direct.table[direct.table >= 0]] == 1).all()


def test_occupancy_grid_marks_walls_free_space_and_unknown(room_scan):
    og = _mapped(room_scan).to_occupancy_grid()
    res, o = og.resolution, og.origin

    def cell(x, y):
        return og.data[int((y - o.y) / res), int((x - o.x) / res)]

    assert cell(0.0, 0.0) == 0
    assert cell(4.01, 0.0) == 100
    assert cell(5.5, 0.0) == -1
