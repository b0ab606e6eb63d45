"""Tracking errors against ground truth: the nearest point of a planned outline, and the
setpoint stream; a flight that cuts the square's corners is judged by the outline."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from quadmission.evaluation.tracking import (
    nearest_on_polyline,
    outline_tracking,
    tracking,
)
from sim.geometry import point_segment_distance
from sim.world import Trajectory

ALTITUDE = 1.5  # m
SQUARE = [(1.5, 1.5), (5.5, 1.5), (5.5, 5.5), (1.5, 5.5), (1.5, 1.5)]  # m, closed
RATE_HZ = 100.0  # ground-truth samples per second
SPEED = 0.8  # m/s

coordinate = st.floats(-10.0, 10.0, allow_nan=False, allow_infinity=False)
point = st.tuples(coordinate, coordinate)


def flown(corners: list[tuple[float, float]], z: float = ALTITUDE) -> Trajectory:
    """A flight along the polyline ``corners`` at ``SPEED``, sampled at ``RATE_HZ``."""
    vertices = np.asarray(corners, dtype=np.float64)
    legs = np.linalg.norm(np.diff(vertices, axis=0), axis=1)
    at = np.concatenate([[0.0], np.cumsum(legs)])  # m along the path at each corner
    t = np.arange(0.0, at[-1] / SPEED, 1.0 / RATE_HZ)
    s = t * SPEED
    xy = np.column_stack([np.interp(s, at, vertices[:, i]) for i in range(2)])
    position = np.column_stack([xy, np.full(len(t), z)])
    return Trajectory(t, position, np.tile([1.0, 0.0, 0.0, 0.0], (len(t), 1)),
                      np.zeros_like(position))


def cut_corners(outline: list[tuple[float, float]], cut: float) -> list[tuple[float, float]]:
    """The closed ``outline`` with each corner replaced by a chamfer ``cut`` metres along
    both edges: the path a setpoint stream that rounds the corners flies."""
    vertices = np.asarray(outline[:-1], dtype=np.float64)
    path: list[tuple[float, float]] = []
    for i, corner in enumerate(vertices):
        before, after = vertices[i - 1], vertices[(i + 1) % len(vertices)]
        for neighbour in (before, after):
            direction = (neighbour - corner) / np.linalg.norm(neighbour - corner)
            x, y = corner + cut * direction
            path.append((float(x), float(y)))
    return [*path, path[0]]


@settings(max_examples=200, deadline=None)
@given(p=point, polyline=st.lists(point, min_size=1, max_size=6))
def test_the_nearest_point_is_at_the_distance_to_the_closest_segment(
    p: tuple[float, float], polyline: list[tuple[float, float]]
) -> None:
    nearest = nearest_on_polyline(np.array([p]), np.array(polyline))[0]
    segments = list(itertools.pairwise(polyline)) or [(polyline[0], polyline[0])]
    closest = min(point_segment_distance(p, a, b) for a, b in segments)
    assert math.dist(p, nearest) == pytest.approx(closest, abs=1e-9)
    # and the point is on the polyline: on one of its segments
    assert min(point_segment_distance(tuple(nearest), a, b) for a, b in segments) < 1e-9


def test_a_polyline_without_points_is_refused() -> None:
    with pytest.raises(ValueError, match="no points"):
        nearest_on_polyline(np.zeros((3, 2)), np.zeros((0, 2)))


def test_a_corner_cutting_flight_has_a_larger_error_than_one_on_the_outline() -> None:
    on_outline = flown(SQUARE)
    cutting = flown(cut_corners(SQUARE, 0.8))
    whole = (0.0, math.inf)
    on = outline_tracking(on_outline, SQUARE, ALTITUDE, whole).rmse()
    cut = outline_tracking(cutting, SQUARE, ALTITUDE, whole).rmse()
    assert on["xy"] == pytest.approx(0.0, abs=1e-9)
    assert cut["xy"] is not None and cut["xy"] > 0.05, cut
    # a chamfer 0.8 m along both edges is farthest from them at its middle: 0.4 m off each
    worst = outline_tracking(cutting, SQUARE, ALTITUDE, whole).max_error()
    assert worst == pytest.approx(0.4, abs=0.01)
    # judged against its own setpoints, the same corner-cutting flight is perfect
    setpoints = cutting.position
    against_setpoints = tracking(cutting.t, setpoints, cutting, whole).rmse()
    assert against_setpoints["xy"] == pytest.approx(0.0, abs=1e-9)


def test_being_late_along_the_outline_is_no_error_but_height_off_it_is() -> None:
    on_time = flown(SQUARE)
    # the same path flown 1 s behind its setpoints (held at the start meanwhile), 10 cm high
    lag = round(1.0 * RATE_HZ)
    late_xy = np.vstack([np.repeat(on_time.position[:1, :2], lag, axis=0),
                         on_time.position[:-lag, :2]])
    late = Trajectory(on_time.t, np.column_stack([late_xy, np.full(len(on_time.t),
                                                                  ALTITUDE + 0.1)]),
                      on_time.quaternion, on_time.velocity)
    track = outline_tracking(late, SQUARE, ALTITUDE, (0.0, math.inf))
    rmse = track.rmse()
    assert rmse["xy"] == pytest.approx(0.0, abs=1e-9)  # always on an edge, however late
    assert rmse["z"] == pytest.approx(0.1)
    assert track.max_error() == pytest.approx(0.1)
    assert track.against == "the planned outline"
    # against its setpoints (where it should have been at each instant) the lag counts
    behind = tracking(on_time.t, on_time.position, late, (0.0, math.inf)).rmse()
    assert behind["xy"] is not None and behind["xy"] > 0.5 * SPEED


def test_only_samples_in_the_window_count() -> None:
    truth = flown(cut_corners(SQUARE, 0.8))
    # the first chamfer is flown from t = 0 to 0.8 * sqrt(2) / SPEED; then the first edge
    chamfer_end = 0.8 * math.sqrt(2) / SPEED
    on_edge = outline_tracking(truth, SQUARE, ALTITUDE, (chamfer_end + 0.1, chamfer_end + 2.0))
    assert len(on_edge.t) == pytest.approx(1.9 * RATE_HZ, abs=1)
    assert on_edge.t[0] >= chamfer_end + 0.1 and on_edge.t[-1] < chamfer_end + 2.0
    assert on_edge.rmse()["xy"] == pytest.approx(0.0, abs=1e-9)
    nothing = outline_tracking(truth, SQUARE, ALTITUDE, (math.inf, math.inf))
    assert len(nothing.t) == 0 and nothing.rmse()["xy"] is None and nothing.max_error() is None
