"""The fake Hokuyo's device side, written from the SCIP 2.0 specification independently of the driver's codec:
the models' PP values, the character encoding with its sums, and the synthetic room the fake scans."""

from __future__ import annotations

import math

import numpy as np

MODELS = {  # PP values (DMIN DMAX mm, ARES, AMIN, AMAX, AFRT steps, SCAN rpm), intensity support
    "URG-04LX": dict(dmin=20, dmax=5600, ares=1024, amin=44, amax=725, afrt=384, rpm=600, intensity=False),
    "UST-10LX": dict(dmin=20, dmax=30000, ares=1440, amin=0, amax=1080, afrt=540, rpm=2400, intensity=True),
}
ROOM = (-1.5, 2.5, -1.2, 1.8)  # walls x = -1.5, x = 2.5, y = -1.2, y = 1.8 around the sensor (m)
DOORWAY_X = (0.5, 1.0)  # an open door in the y = 1.8 wall: no echo (error code 1)
GLASS_Y = (-0.2, 0.2)  # a glass pane in the x = 2.5 wall: reads beyond DMAX


def sum_char(payload: bytes) -> bytes:
    return bytes([(sum(payload) & 0x3F) + 0x30])


def encode(value: int, n: int) -> bytes:
    return bytes(((value >> (6 * (n - 1 - k))) & 0x3F) + 0x30 for k in range(n))


def encode_all(values, n: int) -> bytes:
    v = np.asarray(values, np.int64)[:, None] >> (6 * np.arange(n - 1, -1, -1))
    return ((v & 0x3F) + 0x30).astype(np.uint8).tobytes()


def sum_line(payload: bytes) -> bytes:
    return payload + sum_char(payload) + b"\n"


def step_angle(m: dict, step) -> np.ndarray:
    """Angle (rad) of a step: AFRT is straight ahead, 2 pi / ARES per step, counter-clockwise."""
    return (np.asarray(step) - m["afrt"]) * 2.0 * math.pi / m["ares"]


def room_range_mm(m: dict, step) -> np.ndarray:
    """Distance (mm) or error code at each step: the walls of ROOM, the doorway, the glass pane."""
    a = step_angle(m, step)
    c, s = np.cos(a), np.sin(a)
    with np.errstate(divide="ignore", invalid="ignore"):
        tx = np.where(c > 1e-12, ROOM[1] / c, np.where(c < -1e-12, ROOM[0] / c, np.inf))
        ty = np.where(s > 1e-12, ROOM[3] / s, np.where(s < -1e-12, ROOM[2] / s, np.inf))
    t = np.minimum(tx, ty)
    mm = np.round(t * 1000.0).astype(np.int64)
    hit_y, hit_x = t * c, t * s
    mm[(ty <= tx) & (s > 0) & (hit_y >= DOORWAY_X[0]) & (hit_y <= DOORWAY_X[1])] = 1
    mm[(tx < ty) & (c > 0) & (hit_x >= GLASS_Y[0]) & (hit_x <= GLASS_Y[1])] = m["dmax"] + 500
    return mm


def step_intensity(step) -> np.ndarray:
    return 1000 + (np.asarray(step) % 97) * 7


def cluster_values(m: dict, start: int, end: int, cluster: int) -> tuple[np.ndarray, np.ndarray]:
    """(range mm, intensity) per cluster: the nearest valid step of each (its first when none is)."""
    groups = (end - start) // cluster + 1
    steps = start + np.arange(groups * cluster)
    r = room_range_mm(m, steps)
    r[steps > end] = 0
    never = np.iinfo(np.int64).max
    big = np.where(r >= 20, r, never).reshape(groups, cluster)
    k = np.where(big.min(axis=1) < never, big.argmin(axis=1), 0)
    pick = np.arange(groups) * cluster + k
    return r[pick], step_intensity(steps[pick])
