"""The precision landing's pad search against the map: which legs are clear, which search
points are skipped, which legs are flown round. Pure: numpy only, no runtime.

The search flies a square spiral of points around the pad's known position
(:func:`navigation.precision_landing.search_pattern`). Before each leg (the climb to the
search altitude and the approach from where the vehicle is included) the precision-land
node asks the path finder for the way from the vehicle to the leg's end with the request
the navigator sends (clearance 0: the path finder's ``footprint_radius + safety_margin``,
the vehicle's arms, propellers and margin, and its ``vertical_clearance``), so the search
keeps exactly the navigator's clearance from what the map holds, checked by the same
code. :func:`judge_leg` reads the answer:

- the straight line: the leg is clear, flown as the spiral has it;
- the leg's end in an obstacle's clearance, outside the field, or cut off (the path
  finder fails on the goal, or snaps it to a cube beside it): the point is **skipped**,
  the spiral goes on to its next point;
- a way round: the leg is **reshaped**, flown along the planned path (its first
  waypoint, then asked again from there, as the map grows), unless the way round is
  longer than the straight line by more than ``max_detour`` (then the point is skipped:
  the spiral's next ring passes near it anyway). A contest team wants the search to
  look where the pad may be, and an obstacle beside the pad is where the spiral's points
  are most often cut off from each other: skipping every point behind it would leave that
  side unsearched;
- no answer from the map (no path finder, no map yet, or the vehicle itself inside a
  clearance, which says nothing of the leg: the navigator's rule): the leg is flown as
  before, so a search with nothing mapped near the pad is the spiral it always was.

Map frame (ENU), metres.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
Point = tuple[float, float, float]
END_TOLERANCE_M = 1e-6  # m, a path to a point that ends farther away snapped it: not free


class PlanAnswer(Enum):
    """What the path finder said of a leg (the node maps its result codes here)."""

    PATH = "path"  # a path from the start to the goal (or to a cube beside it)
    BLOCKED = "blocked"  # the goal is in an obstacle's clearance, outside the field, cut off
    UNKNOWN = "unknown"  # no path finder, no map yet, the start inside a clearance


class LegKind(Enum):
    """How a search leg is flown."""

    CLEAR = "clear"  # straight to the search point
    VIA = "via"  # to a waypoint of the planned way round, then asked again
    SKIP = "skip"  # the search point is not flown to
    UNCHECKED = "unchecked"  # straight to the search point: the map said nothing


@dataclass(frozen=True)
class CheckLeg:
    """Ask the path finder for the way from ``start`` to ``goal`` [m]; answer with
    :meth:`navigation.precision_land_policy.PrecisionLandPolicy.leg_planned`."""

    start: Point
    goal: Point


@dataclass(frozen=True)
class Leg:
    """The verdict on a leg: fly to ``target`` [m] (None for SKIP); ``why`` for the log."""

    kind: LegKind
    target: Point | None
    why: str = ""


def _point(p: npt.ArrayLike) -> Point:
    x, y, z = np.asarray(p, dtype=np.float64).reshape(3)
    return float(x), float(y), float(z)


def _same(a: npt.ArrayLike, b: npt.ArrayLike) -> bool:
    return bool(np.allclose(np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64),
                            rtol=0.0, atol=END_TOLERANCE_M))


def judge_leg(start: npt.ArrayLike, goal: npt.ArrayLike, answer: PlanAnswer,
              path: npt.ArrayLike | None = None, *, max_detour: float) -> Leg:
    """How to fly the search leg from ``start`` to the search point ``goal`` [m], given the
    path finder's ``answer`` and, for PATH, its ``path`` (N, 3) [m] from the start (or the
    free cube it snapped the start to) to the goal. See the module docstring."""
    g = np.asarray(goal, dtype=np.float64).reshape(3)
    if answer is PlanAnswer.UNKNOWN:
        return Leg(LegKind.UNCHECKED, _point(g), "the map says nothing of this leg")
    if answer is PlanAnswer.BLOCKED or path is None:
        return Leg(LegKind.SKIP, None, "the search point is in an obstacle's clearance or "
                                       "cut off")
    p = np.asarray(path, dtype=np.float64).reshape(-1, 3)
    if len(p) == 0 or not _same(p[-1], g):
        return Leg(LegKind.SKIP, None, "the search point is in an obstacle's clearance")
    s = np.asarray(start, dtype=np.float64).reshape(3)
    way = np.vstack([s, p]) if not _same(p[0], s) else p
    length = float(np.linalg.norm(np.diff(way, axis=0), axis=1).sum())
    detour = length - float(np.linalg.norm(g - s))
    if detour > max_detour:
        return Leg(LegKind.SKIP, None, f"the way round is {detour:.1f} m longer than the "
                                       f"straight line (more than {max_detour:g} m)")
    if len(way) == 2:
        return Leg(LegKind.CLEAR, _point(g))
    return Leg(LegKind.VIA, _point(way[1]), f"round an obstacle, {detour:.1f} m longer")


__all__ = ["CheckLeg", "Leg", "LegKind", "PlanAnswer", "judge_leg"]
