"""How the navigator follows a planned path at its corners (pure: numpy only).

An intermediate waypoint is reached inside a sphere, and the next leg starts from where
the vehicle was then: the flown path takes the chord, inside the corner. Entering the
sphere of radius ``r`` and turning by ``theta`` there, the chord passes ``r sin(theta)``
inside the waypoint (for a next waypoint far away). The planner's clearance is measured
from the planned polyline, so :func:`corner_radius` bounds that cut by ``max_cut``: the
sphere shrinks at sharp corners (``max_cut / sin(theta)``, at most ``waypoint_radius``).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt


def turn_angle(path: npt.ArrayLike, i: int) -> float:
    """The heading change [rad, 0..pi] at waypoint ``i`` of ``path`` (N, 3) [m],
    horizontally; 0 at the ends and where a leg has no horizontal length."""
    p = np.asarray(path, dtype=np.float64).reshape(-1, 3)
    if i <= 0 or i >= len(p) - 1:
        return 0.0
    a, b = p[i, :2] - p[i - 1, :2], p[i + 1, :2] - p[i, :2]
    na, nb = float(np.hypot(*a)), float(np.hypot(*b))
    if na < 1e-9 or nb < 1e-9:
        return 0.0
    return math.acos(max(-1.0, min(1.0, float(a @ b) / (na * nb))))


def corner_radius(path: npt.ArrayLike, i: int, waypoint_radius: float,
                  max_cut: float) -> float:
    """The reach radius [m] at intermediate waypoint ``i``: ``waypoint_radius``, shrunk so
    that the chord cuts the corner by at most ``max_cut`` [m] (see the module docstring)."""
    s = math.sin(min(turn_angle(path, i), math.pi / 2.0))
    return waypoint_radius if s * waypoint_radius <= max_cut else max_cut / s


__all__ = ["corner_radius", "turn_angle"]
