"""Tiny worlds for the simulator tests."""

from __future__ import annotations

from robot_side.sim.world import World


def wall_world(dist: float, height: float = 2.0, half_width: float = 5.0, res: float = 0.02,
               extra_boxes: list[dict] | None = None) -> World:
    """An open world with a wall facing the origin: its near face at x = dist, spanning |y| <= half_width."""
    return World.from_shapes({
        "bounds": [-1.0, -half_width - 1.0, dist + 1.0, half_width + 1.0],
        "resolution": res,
        "boxes": [{"center": [dist + 0.1, 0.0], "size": [0.2, 2 * half_width], "height": height}]
        + (extra_boxes or []),
    })


def empty_world(size: float = 20.0, res: float = 0.1) -> World:
    return World.from_shapes({"bounds": [-size, -size, size, size], "resolution": res})
