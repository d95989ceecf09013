import numpy as np
import pytest

from common.geometry import Pose2D
from common.messages import Header, OccupancyGrid
from master_side.mapping.map_io import MapFormatError, load_map, read_pgm, save_map


def _grid() -> OccupancyGrid:
    rng = np.random.default_rng(0)
    data = rng.choice(np.array([-1, 0, 100], np.int8), size=(37, 53))
    return OccupancyGrid(Header(0.0, "map"), 0.05, Pose2D(-1.25, 3.5, 0.0), data)


def test_trinary_map_survives_save_and_load(tmp_path):
    g = _grid()
    yp = save_map(g, tmp_path / "m")
    back = load_map(yp)
    assert np.array_equal(back.data, g.data)
    assert back.resolution == pytest.approx(g.resolution)
    assert (back.origin.x, back.origin.y) == pytest.approx((g.origin.x, g.origin.y))


def test_saved_pixels_follow_map_saver_and_row_zero_is_the_top(tmp_path):
    g = _grid()
    save_map(g, tmp_path / "m")
    img = read_pgm(tmp_path / "m.pgm")
    assert set(np.unique(img)) <= {0, 205, 254}
    assert img[0, 0] == {-1: 205, 0: 254, 100: 0}[int(g.data[-1, 0])]


def test_ascii_pgm_and_negate_are_read(tmp_path):
    (tmp_path / "a.pgm").write_text("P2\n# c\n3 2\n255\n0 255 205\n255 0 10\n")
    (tmp_path / "a.yaml").write_text("image: a.pgm\nresolution: 0.1\norigin: [0, 0, 0]\nnegate: 1\n"
                                     "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    g = load_map(tmp_path / "a.yaml")
    assert g.data.tolist() == [[100, 0, 0], [0, 100, 100]]  # bottom image row first


def test_missing_keys_and_bad_images_are_reported(tmp_path):
    (tmp_path / "b.yaml").write_text("image: b.pgm\n")
    with pytest.raises(MapFormatError):
        load_map(tmp_path / "b.yaml")
    (tmp_path / "c.pgm").write_bytes(b"P6\n1 1\n255\n\x00\x00\x00")
    with pytest.raises(MapFormatError):
        read_pgm(tmp_path / "c.pgm")
