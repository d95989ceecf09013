"""A PNG writer for RGB pictures the benchmarks leave beside their maps (no imaging library needed)."""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np


def write_png(path: str | Path, rgb: np.ndarray) -> None:
    """``rgb``: (rows, cols, 3) uint8, row 0 at the top. 8-bit truecolour, every row unfiltered."""
    a = np.ascontiguousarray(rgb, dtype=np.uint8)
    if a.ndim != 3 or a.shape[2] != 3:
        raise ValueError(f"an RGB picture is (rows, cols, 3), not {a.shape}")
    h, w = a.shape[:2]
    raw = np.hstack((np.zeros((h, 1), np.uint8), a.reshape(h, w * 3))).tobytes()  # filter type 0 per row

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    Path(path).write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
                           + chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b""))
