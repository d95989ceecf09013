"""Minimal PGM (P2 ASCII / P5 binary, 8 or 16 bit) reader and writer, as map_server uses them.

Shared by the simulator's world loader and the map server / saver."""

from __future__ import annotations

from pathlib import Path

import numpy as np


class PgmError(ValueError):
    """A file that is not a readable PGM image."""


def _tokens(data: bytes, count: int, pos: int) -> tuple[list[int], int]:
    """Read ``count`` whitespace-separated integers from the header, skipping # comments."""
    out: list[int] = []
    n = len(data)
    while len(out) < count:
        while pos < n and data[pos:pos + 1].isspace():
            pos += 1
        if pos < n and data[pos:pos + 1] == b"#":
            while pos < n and data[pos:pos + 1] not in (b"\n", b"\r"):
                pos += 1
            continue
        start = pos
        while pos < n and not data[pos:pos + 1].isspace() and data[pos:pos + 1] != b"#":
            pos += 1
        if start == pos:
            raise PgmError("truncated PGM header")
        try:
            out.append(int(data[start:pos]))
        except ValueError:
            raise PgmError(f"bad PGM header value {data[start:pos]!r}") from None
    return out, pos


def read_pgm(path: str | Path) -> np.ndarray:
    """Return the image as a (rows, cols) uint8/uint16 array in image order (row 0 at the top)."""
    data = Path(path).read_bytes()
    magic = data[:2]
    if magic not in (b"P2", b"P5"):
        raise PgmError(f"{path}: not a PGM file (magic {magic!r})")
    (w, h, maxval), pos = _tokens(data, 3, 2)
    if not (0 < maxval < 65536):
        raise PgmError(f"{path}: bad maxval {maxval}")
    dtype = np.uint8 if maxval < 256 else np.dtype(">u2")
    if magic == b"P5":
        pos += 1  # exactly one whitespace byte after maxval
        need = w * h * np.dtype(dtype).itemsize
        if len(data) - pos < need:
            raise PgmError(f"{path}: truncated PGM data")
        img = np.frombuffer(data, dtype=dtype, count=w * h, offset=pos).reshape(h, w)
    else:
        vals, _ = _tokens(data, w * h, pos)
        img = np.asarray(vals, dtype=dtype).reshape(h, w)
    return img.astype(np.uint8 if maxval < 256 else np.uint16)


def write_pgm(path: str | Path, img: np.ndarray, comment: str = "") -> None:
    """Write a (rows, cols) uint8 image as binary P5 (with an optional header comment)."""
    a = np.ascontiguousarray(img, dtype=np.uint8)
    head = b"P5\n" + (f"# {comment}\n".encode() if comment else b"") + f"{a.shape[1]} {a.shape[0]}\n255\n".encode()
    Path(path).write_bytes(head + a.tobytes())
