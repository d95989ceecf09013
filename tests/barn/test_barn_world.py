"""BARN training worlds as simulator worlds: conversion, rasterisation fidelity, reference lengths."""

import math

import numpy as np
import pytest

from common.geometry import Pose2D
from deploy.barn import rules as bench
from robot_side.sim.base import DiffDriveBase, base_preset
from robot_side.sim.laser import Laser
from robot_side.sim.simulator import WORLDS_DIR
from robot_side.sim.world import World, load_world
from robot_side.worlds import barn

R = barn.CYLINDER_RADIUS


@pytest.fixture(scope="module")
def worlds(shared_dir):
    return {i: bench.load_cylinders(i) for i in bench.training_worlds()}


def _one_cylinder(cx: float, cy: float, res: float, bounds=(-0.3, -0.3, 0.3, 0.3)) -> World:
    return World.from_shapes({"bounds": list(bounds), "resolution": res,
                              "cylinders": [{"center": [cx, cy], "radius": R, "height": 1.0}]})


def test_there_are_250_training_worlds_none_a_test_world(worlds):
    assert len(worlds) == 250
    assert all(i % 6 != 0 for i in worlds)


def test_every_world_converts_with_its_box_and_a_free_start_goal_and_path(worlds):
    jackal = base_preset("jackal")
    box0 = None
    for i, cyl in worlds.items():
        spec = barn.barn_world_spec(cyl, name=f"barn_{i}")
        assert len(spec["cylinders"]) == len(cyl)
        box = np.round(cyl[barn.box_mask(cyl)], 4)
        assert len(box) == barn.BOX_CYLINDERS
        box0 = box if box0 is None else box0
        assert np.array_equal(box, box0), f"world {i}: another box"
        w = World.from_shapes(spec)
        assert w.start == Pose2D(*barn.START)
        base = DiffDriveBase(w, jackal)
        assert len(base.footprint_hits(w.start)) == 0, f"world {i}: the Jackal collides at the start"
        g = w.goals["goal"]
        assert len(base.footprint_hits(Pose2D(g.x, g.y, barn.START[2]))) == 0
        pts = barn.path_xy(bench.load_path(i))
        assert not w.height_at(pts[:, 0], pts[:, 1]).any(), f"world {i}: a path cell lies in a cylinder"
        # the field and its box are all there is: nothing outside x in [-4.5, 0], y in [0, 9.6]
        ys, xs = np.nonzero(w.heights)
        x0, y0 = w.origin
        assert x0 + xs.min() * w.resolution >= -4.5 - 1e-9
        assert x0 + (xs.max() + 1) * w.resolution <= 0.0 + 1e-9
        assert y0 + (ys.max() + 1) * w.resolution <= barn.FIELD[3] + 1e-9


def test_bounds_hold_box_field_start_and_goal_with_room_to_drive_past_the_goal(worlds):
    for cyl in list(worlds.values())[:10]:
        xmin, ymin, xmax, ymax = barn.barn_world_spec(cyl)["bounds"]
        assert xmin <= barn.FIELD[0] - 1.5
        assert xmax >= barn.FIELD[2] + 1.5
        assert ymin <= -1.5
        assert ymax >= barn.GOAL[1] + 1.5


def test_every_cylinder_rasterises_to_the_same_cells_close_to_pi_r2(worlds):
    res = barn.RESOLUTION
    spec = barn.barn_world_spec(worlds[1])
    single = World.from_shapes({**spec, "cylinders": spec["cylinders"][:1]})
    cells = int((single.heights > 0).sum())
    assert cells * res * res == pytest.approx(math.pi * R * R, rel=0.01)
    # cylinders touch but never share a cell, so every one of them has exactly those cells
    w = World.from_shapes(spec)
    assert int((w.heights > 0).sum()) == cells * len(spec["cylinders"])
    # a cylinder centre is a cell centre
    ix, iy = w.cell_of(-2.325, 7.575)
    assert w.origin[0] + (ix + 0.5) * res == pytest.approx(-2.325, abs=1e-9)
    assert w.origin[1] + (iy + 0.5) * res == pytest.approx(7.575, abs=1e-9)


def test_the_resolution_keeps_any_cylinder_within_3_percent_of_pi_r2():
    rng = np.random.default_rng(0)
    for cx, cy in rng.uniform(0.0, barn.RESOLUTION, (100, 2)):
        w = _one_cylinder(cx, cy, barn.RESOLUTION)
        area = (w.heights > 0).sum() * barn.RESOLUTION ** 2
        assert area == pytest.approx(math.pi * R * R, rel=0.03)


def test_laser_ranges_to_a_cylinder_match_the_circle_within_a_cell():
    c = (1.5, 0.2)
    w = _one_cylinder(*c, barn.RESOLUTION, bounds=(-0.5, -1.0, 2.0, 1.0))
    laser = Laser(w, Laser.preset("hokuyo_ust10lx", x=0.0, noise_std=0.0))
    r = laser.ranges_exact(Pose2D())
    a = laser.angles
    d = np.array([math.cos(v) for v in a]), np.array([math.sin(v) for v in a])
    # ray-circle intersection: |t d - c|^2 = R^2
    b = d[0] * c[0] + d[1] * c[1]
    off = np.sqrt(np.maximum(c[0] ** 2 + c[1] ** 2 - b ** 2, 0.0))  # ray's distance from the centre
    inner = (b > 0) & (off < R - barn.RESOLUTION)
    assert inner.sum() >= 5
    truth = b[inner] - np.sqrt(R * R - off[inner] ** 2)
    assert np.max(np.abs(r[inner] - truth)) < barn.RESOLUTION
    assert np.all(np.isinf(r[(off > R + barn.RESOLUTION) | (b < 0)]))


def test_touching_cylinders_leak_no_beam(worlds):
    """The box's back wall is a row of touching cylinders: no beam aimed at it gets through."""
    w = World.from_shapes(barn.barn_world_spec(worlds[1]))
    laser = Laser(w, Laser.preset("hokuyo_ust10lx", x=0.0, noise_std=0.0))
    r = laser.ranges_exact(Pose2D(-2.25, 1.0, -math.pi / 2))  # facing the back wall at y = 0.075
    a = laser.angles - math.pi / 2
    with np.errstate(divide="ignore"):
        along = np.cos(a) * 0.925 / -np.sin(a)  # x offset where the beam crosses y = 0.075
    aimed = (np.sin(a) < 0) & (np.abs(along) < 1.95)  # between the side walls
    assert aimed.sum() > 300
    assert np.all(r[aimed] * -np.sin(a[aimed]) <= 0.925 + 1e-9)


def test_reference_length_follows_the_readme_formula():
    cells = np.array([[15, 0], [15, 0], [15, 29]])
    x = 0.15 * 15 - 4.575
    want = math.hypot(x + 2.25, 5.075 - 3.0) + 0.15 * 29 + math.hypot(-2.25 - x, 13.0 - (5.075 + 0.15 * 29))
    assert barn.reference_path_length(cells) == pytest.approx(want, abs=1e-12)


def test_reference_lengths_are_in_the_readme_range(worlds):
    lengths = [bench.reference_length(i) for i in worlds]
    assert min(lengths) >= 10.0
    assert max(lengths) <= 13.9
    assert bench.optimal_time(lengths[0]) == pytest.approx(lengths[0] / 2.0)


def test_written_world_loads_as_the_spec(worlds, tmp_path):
    path = bench.write_world(5, tmp_path)
    assert path == tmp_path / "barn_5.yaml"
    w = load_world(path)
    ref = World.from_shapes(barn.barn_world_spec(worlds[5], name="barn_5"))
    assert w.name == "barn_5"
    assert (w.resolution, w.origin, w.start) == (ref.resolution, ref.origin, ref.start)
    assert np.array_equal(w.heights, ref.heights)
    assert w.goals["goal"] == Pose2D(barn.GOAL[0], barn.GOAL[1], 0.0)
    assert path.read_text().startswith("# BARN training world 5 ")


def test_shipped_demo_world_is_training_world_23_as_written(shared_dir, tmp_path):
    shipped = (WORLDS_DIR / "barn_demo.yaml").read_text()
    assert shipped == bench.write_world(23, tmp_path, name="barn_demo").read_text()
    assert "world 23" in shipped.splitlines()[0]


def test_unknown_world_is_a_clear_error(shared_dir):
    with pytest.raises(KeyError, match="training world"):
        bench.load_cylinders(6)
