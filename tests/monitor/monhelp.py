"""Helpers for monitor tests: loopback bus configs, waiting, reading a recording back."""

from __future__ import annotations

import time
from pathlib import Path

import pyarrow as pa
import pytest
from rerun.chunk import RrdReader

from deploy.stack.process_group import checkout_env
from tests.support import free_port  # noqa: F401

REPO = Path(__file__).resolve().parents[2]
FOOTER_MAGIC = b"RRF2FOOT"


def wait_for(cond, timeout: float = 30.0, what: str = "condition", step: float = 0.05):
    end = time.monotonic() + timeout
    while True:
        v = cond()
        if v:
            return v
        if time.monotonic() > end:
            pytest.fail(f"timed out after {timeout:.0f} s waiting for {what}")
        time.sleep(step)


def child_env(robot: str, connect: str) -> dict[str, str]:
    env = checkout_env(drop_zenav=True)
    env.update(ZENAV_ROBOT=robot, ZENAV_MULTICAST="0", ZENAV_CONNECT=connect)
    return env


def has_footer(path: Path) -> bool:
    """A properly closed .rrd ends with the footer magic (``RRF2FOOT`` + version)."""
    with open(path, "rb") as f:
        f.seek(max(0, path.stat().st_size - 16))
        return FOOTER_MAGIC in f.read()


def read_rrd(path: Path) -> dict[str, list[dict]]:
    """entity path -> rows (dicts of component -> value), sorted by ``stamp`` when present.

    Timeline columns are returned as integers (ns); ``_stamp_type`` holds the arrow type of ``stamp``.
    """
    out: dict[str, list[dict]] = {}
    for chunk in RrdReader(str(path)).stream().to_chunks():
        rb = chunk.to_record_batch()
        cols = {}
        for name in rb.schema.names:
            col = rb.column(name)
            if pa.types.is_timestamp(col.type) or pa.types.is_duration(col.type):
                cols[name] = col.cast(pa.int64()).to_pylist()
                cols["_stamp_type" if name == "stamp" else f"_{name}_type"] = [str(col.type)] * len(col)
            else:
                cols[name] = col.to_pylist()
        rows = [dict(zip(cols, vals)) for vals in zip(*cols.values())]
        out.setdefault(chunk.entity_path, []).extend(rows)
    for rows in out.values():
        rows.sort(key=lambda r: r.get("stamp") or 0)
    return out


def values(rows: list[dict], component: str) -> list:
    """The non-null values of ``component`` (each a list, as logged) in row order."""
    return [r[component] for r in rows if r.get(component) is not None]


def asymmetric_grid(width_m: float = 8.0, height_m: float = 6.0, res: float = 0.1,
                    origin: tuple[float, float] = (-3.0, -2.0)):
    """An OccupancyGrid (ROS rows: row 0 = lowest y) that is free inside a wall, with one occupied block in
    the top-right quadrant only (x in 60-80 %, y in 65-85 % of the map), so a mirror in x or y moves it.
    Returns (grid, (x, y) of the block's centre in the map frame)."""
    import numpy as np

    from common import messages as m
    from common.geometry import Pose2D

    w, h = round(width_m / res), round(height_m / res)
    d = np.zeros((h, w), np.int8)
    d[0, :] = d[-1, :] = d[:, 0] = d[:, -1] = 100
    r0, r1, c0, c1 = round(0.65 * h), round(0.85 * h), round(0.6 * w), round(0.8 * w)
    d[r0:r1, c0:c1] = 100
    centre = (origin[0] + res * (c0 + c1) / 2, origin[1] + res * (r0 + r1) / 2)
    return m.OccupancyGrid(m.Header(0.0, "map"), res, Pose2D(origin[0], origin[1], 0.0), d), centre
