"""The matcher tests' shared setup: parameters, map box and a room mapped from one pose."""

from common.geometry import Pose2D
from master_side.slam.grid import TiledGrid
from master_side.slam.gridslam import integrate, prepare_beams
from master_side.slam.params import GMappingParams

P = GMappingParams(maxUrange=20.0, maxRange=25.0, search_linear=0.4, search_angular=0.15)
BOX = (-6, -5, 6, 5)


def room_grid(room_scan, truth: Pose2D) -> TiledGrid:
    """The room's scan from ``truth`` integrated three times into a fresh tiled grid."""
    grid = TiledGrid(P.delta, halo=P.field_radius)
    beams = prepare_beams(room_scan(truth), P, Pose2D())
    for _ in range(3):
        win = grid.window(*BOX)
        grid.store(win, integrate(win, truth.as_array(), beams))
    return grid
