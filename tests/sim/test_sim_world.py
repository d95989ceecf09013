import math

import numpy as np
import pytest

from common.config import ConfigError
from common.geometry import Pose2D
from common.pgm import read_pgm, write_pgm
from robot_side.sim.base import DiffDriveBase
from robot_side.sim.simulator import WORLDS_DIR
from robot_side.sim.world import World, WorldParams, load_world


def _map(tmp_path, img, **yaml_extra):
    write_pgm(tmp_path / "m.pgm", img)
    lines = ["image: m.pgm", "resolution: 0.1", "origin: [-1.0, -2.0, 0.0]", "occupied_thresh: 0.65",
             "free_thresh: 0.196", *(f"{k}: {v}" for k, v in yaml_extra.items())]
    (tmp_path / "m.yaml").write_text("\n".join(lines) + "\n")
    return tmp_path / "m.yaml"


def _img():
    img = np.full((8, 10), 254, np.uint8)  # free
    img[0, 0] = 0  # occupied, top-left pixel = highest y, lowest x
    img[7, 9] = 0  # occupied, bottom-right = lowest y, highest x
    img[3, 4] = 205  # unknown
    return img


def test_map_server_map_becomes_obstacles_with_height(tmp_path):
    w = load_world(_map(tmp_path, _img()), WorldParams(resolution=0.05, map_obstacle_height=1.5))
    assert w.bounds == pytest.approx((-1.0, -2.0, 0.0, -1.2))
    h = lambda x, y: float(w.height_at(np.array([x]), np.array([y]))[0])  # noqa: E731
    assert h(-0.95, -1.25) == 1.5  # image (0, 0) -> top-left of the map
    assert h(-0.05, -1.95) == 1.5  # image (7, 9) -> bottom-right
    assert h(-0.55, -1.55) == 0.0  # unknown counts as free by default
    assert h(-0.5, -1.6) == 0.0
    assert w.occupied().sum() == 2 * 4  # two map cells, each 2x2 sim cells


def test_map_unknown_negate_and_height_override(tmp_path):
    w = load_world(_map(tmp_path, _img(), obstacle_height=0.7), WorldParams(unknown_is_obstacle=True))
    assert w.heights.max() == pytest.approx(0.7)
    assert w.occupied().sum() == 3 * 25
    w = load_world(_map(tmp_path, 255 - _img(), negate=1))
    assert w.occupied().sum() == 2 * 25


def test_edge_walls_end_a_map_world_at_its_edge(tmp_path):
    """Without them the floor goes on beyond the map (a ray through an opening in an outer wall finds nothing,
    the robot can drive off); with them the world's free space is the map's."""
    img = np.full((8, 10), 254, np.uint8)
    img[:, 5] = 0  # a wall across the map with one opening
    img[4, 5] = 254
    img[0, 0] = img[-1, -1] = 0  # and content in two corners: it spans the map, whose edge is then the world's
    open_ = load_world(_map(tmp_path, img), WorldParams(resolution=0.05))
    closed = load_world(_map(tmp_path, img), WorldParams(resolution=0.05, edge_walls=True))
    assert not open_.occupied()[2:-2, [0, -1]].any()  # free floor up to the edge, and beyond it
    assert closed.occupied()[[0, -1], :].all() and closed.occupied()[:, [0, -1]].all()  # walls along its edge
    assert (open_.occupied() & ~closed.occupied()).sum() == 0  # the map's own walls are kept
    # from a start left of the wall, the opening joins both sides: one region, inside the edge
    reach = closed.with_start(Pose2D(-0.75, -1.6, 0.0)).to_occupancy_grid(unknown_unreachable=True).data
    assert (reach == 0).sum() == (~closed.occupied()).sum() > 0.6 * closed.occupied().size


def test_edge_walls_cut_the_free_margin_outside_a_buildings_outer_wall(tmp_path):
    """MRPB's mall: free floor all round outside its outer wall, which has openings — an alley the robot can
    enter and not turn in. With edge_walls the world ends at the bounding box of the map's walls and unknown
    cells: the margin is wall, the opening ends at it, the inside is the only free space."""
    img = np.full((14, 16), 254, np.uint8)  # a 2-pixel free margin all round
    img[2, 2:14] = img[11, 2:14] = 205  # the outer wall, drawn as unknown and occupied cells
    img[2:12, 2] = img[2:12, 13] = 0
    img[2, 7] = 254  # an opening in the top wall, onto the margin
    closed = load_world(_map(tmp_path, img), WorldParams(resolution=0.1, edge_walls=True, unknown_is_obstacle=True))
    occ = closed.occupied()[::-1]  # image orientation: row 0 at the top
    assert occ[:2, :].all() and occ[12:, :].all() and occ[:, :2].all() and occ[:, 14:].all()  # margin: wall
    assert not occ[3:11, 3:13].any()  # the inside stays free
    assert not occ[2, 7]  # the opening too, ending at the wall beyond it
    reach = closed.with_start(Pose2D(-0.3, -0.7, 0.0)).to_occupancy_grid(unknown_unreachable=True).data
    assert (reach == 0).sum() == 8 * 10 + 1  # the inside and its opening: nothing outside
    # before: the margin was free and joined to the inside through the opening
    walled_edge = load_world(_map(tmp_path, img), WorldParams(resolution=0.1, unknown_is_obstacle=True))
    assert not walled_edge.occupied()[::-1][0, :].any()


def test_ascii_pgm(tmp_path):
    (tmp_path / "a.pgm").write_text("P2\n# comment\n3 2\n255\n0 128 255\n10 20 30\n")
    np.testing.assert_array_equal(read_pgm(tmp_path / "a.pgm"), [[0, 128, 255], [10, 20, 30]])


def test_shapes_rasterise_with_heights():
    w = World.from_shapes({
        "bounds": [-3, -3, 3, 3],
        "walls": [{"from": [-2, 2], "to": [2, 2], "thickness": 0.2, "height": 2.5}],
        "boxes": [{"center": [0, 0], "size": [1.0, 0.4], "yaw": math.pi / 4, "height": 0.5}],
        "cylinders": [{"center": [-1.5, -1.5], "radius": 0.3, "height": 0.8},
                      {"center": [0.3, 0.3], "radius": 0.1, "height": 0.9}],
        "start": [1, -1, 0.5], "goals": {"g": [2, 0, 0]},
    })
    h = lambda x, y: float(w.height_at(np.array([x]), np.array([y]))[0])  # noqa: E731
    assert h(0, 2.05) == 2.5
    assert h(2.05, 2) == 2.5
    assert h(0, 2.15) == 0.0
    assert h(0.3, 0.3) == pytest.approx(0.9)  # overlapping shapes: the max height
    assert h(-0.25, -0.25) == pytest.approx(0.5)
    assert h(0.4, -0.4) == 0.0
    assert h(-1.5 + 0.27, -1.5) == pytest.approx(0.8)
    assert h(-1.5 + 0.33, -1.5) == 0.0
    assert w.start == Pose2D(1, -1, 0.5)
    assert w.goals == {"g": Pose2D(2, 0, 0)}
    assert w.with_start([0, 0, 1]).start == Pose2D(0, 0, 1)
    grid = w.to_occupancy_grid(min_height=1.0)
    assert grid.data.max() == 100
    assert (grid.data == 100).sum() == (w.heights > 1.0).sum()


def test_occupancy_grid_marks_space_unreachable_from_the_start_unknown():
    spec = {"bounds": [-2, -2, 2, 2], "start": [0, 0, 0], "resolution": 0.1,
            "walls": [{"from": [-1.5, -1.5], "to": [1.5, -1.5], "thickness": 0.2, "height": 1},
                      {"from": [1.5, -1.5], "to": [1.5, 1.5], "thickness": 0.2, "height": 1},
                      {"from": [1.5, 1.5], "to": [-1.5, 1.5], "thickness": 0.2, "height": 1},
                      {"from": [-1.5, 1.5], "to": [-1.5, -1.5], "thickness": 0.2, "height": 1}]}
    w = World.from_shapes(spec)
    plain, known = w.to_occupancy_grid(0.05), w.to_occupancy_grid(0.05, unknown_unreachable=True)
    assert (plain.data >= 0).all()
    assert ((known.data == 100) == (plain.data == 100)).all()  # walls unchanged

    def value(grid, x, y):
        ix, iy = w.cell_of(x, y)
        return int(grid.data[iy, ix])

    assert value(known, 0.0, 0.0) == 0 and value(known, 1.2, -1.2) == 0  # inside the walls: free
    assert value(known, 1.85, 0.0) == -1 and value(known, -1.9, 1.9) == -1  # outside: never seen
    assert value(plain, 1.85, 0.0) == 0
    outside = w.with_start([1.85, 1.85, 0]).to_occupancy_grid(0.05, unknown_unreachable=True)
    assert value(outside, 0.0, 0.0) == -1 and value(outside, 1.85, 0.0) == 0  # follows the start


def test_bad_shapes_are_reported_with_the_key():
    with pytest.raises(ConfigError, match=r"boxes\[0\].colour"):
        World.from_shapes({"boxes": [{"center": [0, 0], "size": [1, 1], "height": 1, "colour": "red"}]})
    with pytest.raises(ConfigError, match=r"cylinders\[0\].radius"):
        World.from_shapes({"cylinders": [{"center": [0, 0], "height": 1}]})
    with pytest.raises(ConfigError, match="bounds"):
        World.from_shapes({})


@pytest.mark.parametrize("name", ["room", "corridor"])
def test_shipped_worlds_have_free_start_and_goals(name):
    w = load_world(WORLDS_DIR / f"{name}.yaml")
    base = DiffDriveBase(w)
    assert len(w.goals) >= 2
    for pose in [w.start, *w.goals.values()]:
        assert len(base.footprint_hits(pose)) == 0
    assert load_world(WORLDS_DIR / f"{name}.yaml", start=[0.5, -1.0, 0.0]).start == Pose2D(0.5, -1.0, 0.0)


def test_room_goal_is_behind_the_obstacle():
    w = load_world(WORLDS_DIR / "room.yaml")
    g = w.goals["across_obstacle"]
    t = np.linspace(0, 1, 200)
    xs, ys = w.start.x + t * (g.x - w.start.x), w.start.y + t * (g.y - w.start.y)
    assert (w.height_at(xs, ys) > 0.35).any()
