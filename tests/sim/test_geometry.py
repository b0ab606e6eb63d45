"""Planar geometry behind the arena rules: distances, overlaps, flood fill."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from sim.geometry import (
    FloodGrid,
    Rect,
    point_segment_distance,
    segment_distance,
    segment_rect_distance,
)

coordinate = st.floats(-10.0, 10.0, allow_nan=False, allow_infinity=False)
point = st.tuples(coordinate, coordinate)


def _point_rect_distance(p: tuple[float, float], rect: Rect) -> float:
    dx = max(rect.xmin - p[0], 0.0, p[0] - rect.xmax)
    dy = max(rect.ymin - p[1], 0.0, p[1] - rect.ymax)
    return math.hypot(dx, dy)


def _samples(a: tuple[float, float], b: tuple[float, float], n: int = 400) -> np.ndarray:
    t = np.linspace(0.0, 1.0, n)[:, None]
    return np.asarray(a) + t * (np.asarray(b) - np.asarray(a))


@given(point, point, point, point)
def test_segment_distance_is_symmetric_and_bounded_by_endpoints(a, b, c, d) -> None:
    dist = segment_distance(a, b, c, d)
    assert dist >= 0.0
    assert math.isclose(dist, segment_distance(c, d, a, b), abs_tol=1e-9)
    assert dist <= min(point_segment_distance(a, c, d), point_segment_distance(c, a, b)) + 1e-9


@given(point, point, point, point)
def test_segment_distance_matches_dense_sampling(a, b, c, d) -> None:
    sampled = min(point_segment_distance(tuple(p), c, d) for p in _samples(a, b))
    step = math.dist(a, b) / 399
    assert segment_distance(a, b, c, d) <= sampled + 1e-9
    assert sampled <= segment_distance(a, b, c, d) + step + 1e-9


@given(point, point, point, st.floats(0.01, 5.0), st.floats(0.01, 5.0))
def test_segment_rect_distance_matches_dense_sampling(a, b, center, w, h) -> None:
    rect = Rect.centered(center, (w, h))
    sampled = min(_point_rect_distance(tuple(p), rect) for p in _samples(a, b))
    step = math.dist(a, b) / 399
    analytic = segment_rect_distance(a, b, rect)
    assert analytic <= sampled + 1e-9
    assert sampled <= analytic + step + 1e-9


def test_crossing_segments_are_at_zero_distance() -> None:
    assert segment_distance((0, 0), (2, 2), (0, 2), (2, 0)) == 0.0
    assert segment_distance((0, 0), (1, 0), (2, 0), (3, 0)) == 1.0


def test_touching_rectangles_do_not_overlap() -> None:
    a = Rect(0.0, 0.0, 1.0, 1.0)
    assert not a.overlaps(Rect(1.0, 0.0, 2.0, 1.0))
    assert a.overlaps(Rect(0.99, 0.5, 2.0, 1.0))
    assert Rect(0.0, 0.0, 10.0, 10.0).contains(a)


def test_flood_fill_stops_at_a_closed_ring_and_passes_a_gap() -> None:
    ring = [Rect(2, 2, 8, 3), Rect(2, 7, 8, 8), Rect(2, 2, 3, 8), Rect(7, 2, 8, 8)]
    closed = FloodGrid.from_rects((10.0, 10.0), 0.1, ring)
    inside = closed.reachable_from((5.0, 5.0))
    assert inside[closed.cell((4.0, 4.0))]
    assert not inside[closed.cell((1.0, 1.0))]
    opened = FloodGrid.from_rects(
        (10.0, 10.0), 0.1, [*ring[:3], Rect(7, 2, 8, 4), Rect(7, 5, 8, 8)]
    )
    assert opened.reachable_from((5.0, 5.0))[opened.cell((1.0, 1.0))]
    assert not closed.reachable_from((2.5, 2.5)).any(), "a blocked start reaches nothing"
