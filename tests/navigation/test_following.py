"""The navigator's corner rule (navigation/following.py): the flown chord cuts a corner by
at most ``max_cut``."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from navigation.following import corner_radius, turn_angle

W = np.array([0.0, 0.0, 1.5])


def corner(theta: float, leg: float = 3.0) -> np.ndarray:
    """A path that comes in along +x, turns by ``theta`` at W and goes on for ``leg``."""
    return np.array([W - (leg, 0.0, 0.0), W,
                     W + (leg * math.cos(theta), leg * math.sin(theta), 0.0)])


def test_turn_angle_is_the_heading_change() -> None:
    assert turn_angle(corner(0.0), 1) == 0.0
    assert math.isclose(turn_angle(corner(math.pi / 2), 1), math.pi / 2)
    assert math.isclose(turn_angle(corner(-2.0), 1), 2.0)
    assert turn_angle(corner(1.0), 0) == 0.0 and turn_angle(corner(1.0), 2) == 0.0


def test_straight_on_keeps_the_sphere_and_a_right_angle_shrinks_it_to_the_cut() -> None:
    assert corner_radius(corner(0.0), 1, 0.3, 0.1) == 0.3
    assert corner_radius(corner(math.radians(15)), 1, 0.3, 0.1) == 0.3  # 0.078 m cut
    assert math.isclose(corner_radius(corner(math.pi / 2), 1, 0.3, 0.1), 0.1)
    assert math.isclose(corner_radius(corner(3.0), 1, 0.3, 0.1), 0.1)


@settings(max_examples=60, deadline=None)
@given(theta=st.floats(0.0, math.pi * 0.95), max_cut=st.floats(0.02, 0.3))
def test_the_flown_chord_stays_within_the_cut_of_the_corner(theta: float,
                                                            max_cut: float) -> None:
    """Entering the sphere on the incoming leg and flying straight to the next waypoint:
    the chord passes no farther than ``max_cut`` inside the corner."""
    path = corner(theta)
    r = corner_radius(path, 1, 0.3, max_cut)
    entry = W - (r, 0.0, 0.0)  # where the incoming leg enters the sphere
    d = path[2] - entry
    cut = abs(d[0] * (W - entry)[1] - d[1] * (W - entry)[0]) / float(np.hypot(d[0], d[1]))
    assert cut <= max_cut + 1e-9
