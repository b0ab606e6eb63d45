"""Planar geometry for arena rules: rectangles, segment distances and a flood-fill grid.

All coordinates are metres in the map plane (ENU x east, y north). Rectangles are
axis-aligned; a robot's swept corridor is a segment with a radius.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

Vec2 = tuple[float, float]


@dataclass(frozen=True)
class Rect:
    """Axis-aligned rectangle ``[xmin, xmax] x [ymin, ymax]`` in metres."""

    xmin: float
    ymin: float
    xmax: float
    ymax: float

    @classmethod
    def centered(cls, center: Vec2, size: Vec2) -> Rect:
        """The rectangle of full extents ``size`` centred on ``center``."""
        hx, hy = size[0] / 2.0, size[1] / 2.0
        return cls(center[0] - hx, center[1] - hy, center[0] + hx, center[1] + hy)

    def inflated(self, margin: float) -> Rect:
        """This rectangle grown by ``margin`` on every side (shrunk if negative)."""
        return Rect(self.xmin - margin, self.ymin - margin, self.xmax + margin, self.ymax + margin)

    def overlaps(self, other: Rect) -> bool:
        """True when the two rectangles share a positive area (touching edges do not)."""
        return (
            self.xmin < other.xmax
            and other.xmin < self.xmax
            and self.ymin < other.ymax
            and other.ymin < self.ymax
        )

    def contains(self, other: Rect) -> bool:
        """True when ``other`` lies inside this rectangle (edges included)."""
        return (
            self.xmin <= other.xmin
            and other.xmax <= self.xmax
            and self.ymin <= other.ymin
            and other.ymax <= self.ymax
        )

    def contains_point(self, point: Vec2) -> bool:
        """True when ``point`` lies inside this rectangle (edges included)."""
        return self.xmin <= point[0] <= self.xmax and self.ymin <= point[1] <= self.ymax

    def corners(self) -> tuple[Vec2, Vec2, Vec2, Vec2]:
        """Corners counter-clockwise from ``(xmin, ymin)``."""
        return (
            (self.xmin, self.ymin),
            (self.xmax, self.ymin),
            (self.xmax, self.ymax),
            (self.xmin, self.ymax),
        )


def point_segment_distance(p: Vec2, a: Vec2, b: Vec2) -> float:
    """Euclidean distance from point ``p`` to segment ``ab``."""
    abx, aby = b[0] - a[0], b[1] - a[1]
    length_sq = abx * abx + aby * aby
    if length_sq == 0.0:
        return math.dist(p, a)
    t = ((p[0] - a[0]) * abx + (p[1] - a[1]) * aby) / length_sq
    t = min(1.0, max(0.0, t))
    return math.dist(p, (a[0] + t * abx, a[1] + t * aby))


def _orientation(a: Vec2, b: Vec2, c: Vec2) -> float:
    return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])


def segments_intersect(a: Vec2, b: Vec2, c: Vec2, d: Vec2) -> bool:
    """True when segments ``ab`` and ``cd`` share a point (collinear overlap included)."""
    d1, d2 = _orientation(c, d, a), _orientation(c, d, b)
    d3, d4 = _orientation(a, b, c), _orientation(a, b, d)
    if ((d1 > 0 > d2) or (d1 < 0 < d2)) and ((d3 > 0 > d4) or (d3 < 0 < d4)):
        return True
    # Touching or collinear cases: an endpoint lies on the other segment.
    return (
        (d1 == 0 and point_segment_distance(a, c, d) == 0.0)
        or (d2 == 0 and point_segment_distance(b, c, d) == 0.0)
        or (d3 == 0 and point_segment_distance(c, a, b) == 0.0)
        or (d4 == 0 and point_segment_distance(d, a, b) == 0.0)
    )


def segment_distance(a: Vec2, b: Vec2, c: Vec2, d: Vec2) -> float:
    """Euclidean distance between segments ``ab`` and ``cd`` (0 when they cross)."""
    if segments_intersect(a, b, c, d):
        return 0.0
    return min(
        point_segment_distance(a, c, d),
        point_segment_distance(b, c, d),
        point_segment_distance(c, a, b),
        point_segment_distance(d, a, b),
    )


def segment_rect_distance(a: Vec2, b: Vec2, rect: Rect) -> float:
    """Euclidean distance between segment ``ab`` and the filled rectangle ``rect``."""
    if rect.contains_point(a) or rect.contains_point(b):
        return 0.0
    corners = rect.corners()
    return min(segment_distance(a, b, corners[i], corners[(i + 1) % 4]) for i in range(4))


@dataclass(frozen=True)
class FloodGrid:
    """A boolean free-space grid over ``[0, size_x] x [0, size_y]`` with square cells.

    Cell ``(i, j)`` covers ``x in [i*res, (i+1)*res)``, ``y in [j*res, (j+1)*res)``; it is
    free when its centre lies outside every blocking rectangle.
    """

    free: npt.NDArray[np.bool_]
    resolution: float

    @classmethod
    def from_rects(cls, size: Vec2, resolution: float, blocked: Iterable[Rect]) -> FloodGrid:
        """Grid over ``size`` metres; cells whose centres fall in any ``blocked`` are not free."""
        nx = max(1, round(size[0] / resolution))
        ny = max(1, round(size[1] / resolution))
        xs = (np.arange(nx) + 0.5) * resolution
        ys = (np.arange(ny) + 0.5) * resolution
        free = np.ones((nx, ny), dtype=bool)
        for rect in blocked:
            in_x = (xs >= rect.xmin) & (xs <= rect.xmax)
            in_y = (ys >= rect.ymin) & (ys <= rect.ymax)
            free[np.ix_(in_x, in_y)] = False
        free.setflags(write=False)
        return cls(free=free, resolution=resolution)

    def cell(self, point: Vec2) -> tuple[int, int]:
        """Index of the cell holding ``point`` (clamped to the grid)."""
        nx, ny = self.free.shape
        i = min(nx - 1, max(0, int(point[0] / self.resolution)))
        j = min(ny - 1, max(0, int(point[1] / self.resolution)))
        return i, j

    def reachable_from(self, point: Vec2) -> npt.NDArray[np.bool_]:
        """Cells 4-connected to the cell of ``point`` through free cells (none if it is blocked)."""
        reached = np.zeros_like(self.free)
        start = self.cell(point)
        if not self.free[start]:
            return reached
        reached[start] = True
        while True:
            grown = reached.copy()
            grown[1:, :] |= reached[:-1, :]
            grown[:-1, :] |= reached[1:, :]
            grown[:, 1:] |= reached[:, :-1]
            grown[:, :-1] |= reached[:, 1:]
            grown &= self.free
            if np.array_equal(grown, reached):
                return reached
            reached = grown
