"""Independent overlap check for tests: rasterise every footprint and look for shared cells.

Deliberately shares no code with ``sim.geometry``: boxes and pads are filled rectangles,
robots are the discs swept along their paths, sampled on a 5 cm grid (1 m beyond the
field on every side) whose cell centres sit between the 5 cm multiples arenas use.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from sim.arena import PAD_SIZE, ROBOT_RADIUS, ArenaSpec

CELL = 0.05  # m
MARGIN = 1.0  # m
Mask = npt.NDArray[np.bool_]
Grid = npt.NDArray[np.float64]


def _grid(arena: ArenaSpec) -> tuple[Grid, Grid]:
    sx, sy, _ = arena.field.size
    xs = np.arange(-MARGIN + CELL / 2, sx + MARGIN, CELL)
    ys = np.arange(-MARGIN + CELL / 2, sy + MARGIN, CELL)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    return gx, gy


def _box(gx: Grid, gy: Grid, center: Sequence[float], size: Sequence[float]) -> Mask:
    return (np.abs(gx - center[0]) < size[0] / 2) & (np.abs(gy - center[1]) < size[1] / 2)


def _corridor(gx: Grid, gy: Grid, a: Sequence[float], b: Sequence[float]) -> Mask:
    ab = np.subtract(b, a)
    t = np.clip(((gx - a[0]) * ab[0] + (gy - a[1]) * ab[1]) / float(ab @ ab), 0.0, 1.0)
    return np.hypot(gx - (a[0] + t * ab[0]), gy - (a[1] + t * ab[1])) < ROBOT_RADIUS


def footprints(arena: ArenaSpec) -> dict[str, Mask]:
    """``{label: occupied cells}`` for every pad, obstacle and robot corridor."""
    gx, gy = _grid(arena)
    shapes = {f"pad {p.id}": _box(gx, gy, p.center, (PAD_SIZE, PAD_SIZE)) for p in arena.pads}
    for i, box in enumerate(arena.obstacles):
        shapes[f"obstacle {i}"] = _box(gx, gy, box.center, box.size)
    for robot in arena.robots:
        closing = (robot.path[0],) if robot.loop else ()
        swept = np.zeros_like(gx, dtype=bool)
        for a, b in zip(robot.path, robot.path[1:] + closing, strict=False):
            swept |= _corridor(gx, gy, a, b)
        shapes[f"robot {robot.marker_id}"] = swept
    return shapes


def overlapping_pairs(arena: ArenaSpec) -> list[tuple[str, str]]:
    """Footprints sharing a cell, and footprints sticking out of the field (paired "field")."""
    shapes = footprints(arena)
    gx, gy = _grid(arena)
    sx, sy, _ = arena.field.size
    outside = (gx < 0) | (gx > sx) | (gy < 0) | (gy > sy)
    labels = list(shapes)
    pairs = [(label, "field") for label in labels if (shapes[label] & outside).any()]
    pairs += [
        (first, second)
        for i, first in enumerate(labels)
        for second in labels[i + 1 :]
        if (shapes[first] & shapes[second]).any()
    ]
    return pairs
