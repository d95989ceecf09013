"""ROS map_server maps: a PGM image plus a YAML file (image, resolution, origin, thresholds, mode).

Reading follows map_server: p = (255 - v) / 255 (or v / 255 with ``negate``); p > occupied_thresh
-> 100, p < free_thresh -> 0, else -1 (mode trinary); ``scale`` maps linearly in between; ``raw``
keeps the pixel value. Writing follows map_saver: 0 (free) -> 254, 100 (occupied) -> 0, else 205.
Image row 0 is the top (highest y); OccupancyGrid row 0 is the lowest y.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import yaml

from common.geometry import Pose2D
from common.messages import Header, OccupancyGrid
from common.pgm import PgmError, write_pgm
from common.pgm import read_pgm as _read_pgm

FREE_PIXEL, OCCUPIED_PIXEL, UNKNOWN_PIXEL = 254, 0, 205


class MapFormatError(ValueError):
    """A map YAML or PGM that cannot be read."""


def read_pgm(path: str | Path) -> np.ndarray:
    """P5 (binary, 8 or 16 bit) or P2 (ascii) PGM -> (rows, cols) int64 array, row 0 = top."""
    try:
        return _read_pgm(path).astype(np.int64)
    except PgmError as e:
        raise MapFormatError(str(e)) from None



def load_map(yaml_path: str | Path) -> OccupancyGrid:
    """Load a map_server YAML (+ its image, relative to the YAML) as an OccupancyGrid in frame ``map``."""
    yp = Path(yaml_path)
    try:
        meta = yaml.safe_load(yp.read_text())
    except (OSError, yaml.YAMLError) as e:
        raise MapFormatError(f"{yp}: {e}") from e
    for key in ("image", "resolution", "origin"):
        if key not in meta:
            raise MapFormatError(f"{yp}: missing key {key!r}")
    img_path = Path(meta["image"])
    if not img_path.is_absolute():
        img_path = yp.parent / img_path
    img = read_pgm(img_path)
    maxval = 255.0
    negate = bool(int(meta.get("negate", 0)))
    occ_t, free_t = float(meta.get("occupied_thresh", 0.65)), float(meta.get("free_thresh", 0.196))
    mode = meta.get("mode", "trinary")
    p = img / maxval if negate else (maxval - img) / maxval
    if mode == "raw":
        data = img.astype(np.int8)
    else:
        data = np.full(img.shape, -1, np.int8)
        data[p > occ_t] = 100
        data[p < free_t] = 0
        if mode == "scale":
            mid = (p >= free_t) & (p <= occ_t)
            data[mid] = np.round(99 * (p[mid] - free_t) / (occ_t - free_t)).astype(np.int8)
    ox, oy, oyaw = (list(map(float, meta["origin"])) + [0.0, 0.0, 0.0])[:3]
    origin = Pose2D(ox, oy, oyaw)
    return OccupancyGrid(Header(0.0, "map"), float(meta["resolution"]), origin, data[::-1].copy())


def save_map(grid: OccupancyGrid, basename: str | Path, free_thresh: int = 25,
             occupied_thresh: int = 65) -> Path:
    """map_saver: write ``basename.pgm`` and ``basename.yaml``; returns the YAML path."""
    base = Path(basename)
    d = grid.data
    img = np.full(d.shape, UNKNOWN_PIXEL, np.uint8)
    img[(d >= 0) & (d <= free_thresh)] = FREE_PIXEL
    img[d >= occupied_thresh] = OCCUPIED_PIXEL
    pgm = base.with_suffix(".pgm")
    write_pgm(pgm, img[::-1], f"CREATOR: zenav map_saver {grid.resolution:.3f} m/pix "
                              f"{grid.width} x {grid.height}")
    o = grid.origin
    meta = (f"image: {pgm.name}\nresolution: {grid.resolution:.6f}\n"
            f"origin: [{o.x:.6f}, {o.y:.6f}, {0.0 if math.isclose(o.theta, 0.0) else o.theta:.6f}]\n"
            "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\nmode: trinary\n")
    yp = base.with_suffix(".yaml")
    yp.write_text(meta)
    return yp


map_saver = save_map
