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

FREE_PIXEL, OCCUPIED_PIXEL, UNKNOWN_PIXEL = 254, 0, 205


class MapFormatError(ValueError):
    """A map YAML or PGM that cannot be read."""


def _tokens(data: bytes, start: int, count: int) -> tuple[list[int], int]:
    """Read ``count`` whitespace-separated integers (skipping # comments) from byte offset ``start``."""
    out, i, n = [], start, len(data)
    while len(out) < count:
        while i < n and (data[i:i + 1].isspace() or data[i:i + 1] == b"#"):
            if data[i:i + 1] == b"#":
                while i < n and data[i:i + 1] not in (b"\n", b"\r"):
                    i += 1
            else:
                i += 1
        j = i
        while j < n and data[j:j + 1].isdigit():
            j += 1
        if j == i:
            raise MapFormatError("bad PGM header")
        out.append(int(data[i:j]))
        i = j
    return out, i


def read_pgm(path: str | Path) -> np.ndarray:
    """P5 (binary, 8 or 16 bit) or P2 (ascii) PGM -> (rows, cols) array, row 0 = top."""
    data = Path(path).read_bytes()
    magic = data[:2]
    if magic not in (b"P5", b"P2"):
        raise MapFormatError(f"{path}: not a PGM (magic {magic!r})")
    (w, h, maxval), i = _tokens(data, 2, 3)
    if magic == b"P2":
        vals, _ = _tokens(data, i, w * h)
        return np.array(vals, np.int64).reshape(h, w)
    i += 1  # single whitespace after maxval
    dtype = np.uint8 if maxval < 256 else np.dtype(">u2")
    size = w * h * np.dtype(dtype).itemsize
    if len(data) - i < size:
        raise MapFormatError(f"{path}: truncated PGM")
    return np.frombuffer(data, dtype, w * h, i).reshape(h, w).astype(np.int64)


def write_pgm(path: str | Path, img: np.ndarray, comment: str = "") -> None:
    h, w = img.shape
    head = b"P5\n" + (f"# {comment}\n".encode() if comment else b"") + f"{w} {h}\n255\n".encode()
    Path(path).write_bytes(head + np.ascontiguousarray(img, np.uint8).tobytes())


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
