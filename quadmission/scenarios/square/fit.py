"""Fit the square flight to an arena: pure geometry over the arena's description.

The square starts and ends above the start pad (the take-off point is one corner) and is
flown at one altitude. :func:`fit_square` tries the four squares that have that corner
(toward +x+y, -x+y, -x-y, +x-y), each from the largest side down, and keeps the largest
one whose edges stay ``clearance`` away, in the plane, from the walls and from every
obstacle the drone cannot fly over (taller than the altitude minus the vertical
clearance), and from the robots' corridors when the robots are that tall. Nothing fits:
:class:`SquareDoesNotFit`, naming what is in the way.

Map frame (ENU), metres. The arena is prior knowledge of the field (as the contest's map
is), not the simulator's state.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

from quadmission.errors import SquareDoesNotFit
from sim.arena import (
    DRONE_CLEARANCE,
    ROBOT_RADIUS,
    ROBOT_SIZE,
    VERTICAL_CLEARANCE,
    ArenaSpec,
)
from sim.geometry import Rect, Vec2, segment_distance, segment_rect_distance
from sim.mjcf import obstacle_geom_name, robot_body_name

SQUARE_SIDE = 4.0  # m, the side flown when it fits
SQUARE_ALTITUDE = 1.5  # m, above the floor
MIN_SIDE = 1.0  # m, a smaller square is refused
SIDE_STEP = 0.25  # m, the side shrinks by this much until the square fits
#: Horizontal room between the drone's centre and anything it must not touch: its
#: footprint (DRONE_CLEARANCE, larger than the rotor tips' 0.35 m) plus the worst
#: tracking error measured at a corner (README, results), rounded up.
CLEARANCE = DRONE_CLEARANCE + 0.2  # m
#: The quadrants a square can lie in from its first corner, in order of preference.
DIRECTIONS: tuple[tuple[int, int], ...] = ((1, 1), (-1, 1), (-1, -1), (1, -1))


@dataclass(frozen=True)
class SquarePlan:
    """A square flight: first corner ``start`` (the take-off point), ``side`` along
    ``direction`` (signs of x and y), at ``altitude``."""

    start: Vec2
    side: float
    altitude: float
    direction: tuple[int, int] = (1, 1)

    def outline(self) -> list[Vec2]:
        """The square's corners in flight order, closing on ``start`` (5 points): along x
        first, then y, then back."""
        (x, y), s = self.start, self.side
        dx, dy = self.direction[0] * s, self.direction[1] * s
        return [(x, y), (x + dx, y), (x + dx, y + dy), (x, y + dy), (x, y)]

    def corners(self) -> list[tuple[float, float, float]]:
        """The four reach targets [m], in order, the last one above the start."""
        return [(px, py, self.altitude) for px, py in self.outline()[1:]]

    def edges(self) -> list[tuple[Vec2, Vec2]]:
        points = self.outline()
        return list(itertools.pairwise(points))

    def describe(self) -> str:
        sx, sy = ("+" if d > 0 else "-" for d in self.direction)
        return (f"{self.side:g} m square toward {sx}x{sy}y from ({self.start[0]:g}, "
                f"{self.start[1]:g}) at {self.altitude:g} m")


@dataclass(frozen=True)
class Blocker:
    """Something closer to the square than the clearance: its name and the distance [m]."""

    name: str
    distance: float


def _blockers(arena: ArenaSpec, altitude: float) -> list[tuple[str, Rect | None,
                                                               tuple[Vec2, Vec2] | None, float]]:
    """What the square must keep clear of: (name, rectangle or segment, extra radius)."""
    found: list[tuple[str, Rect | None, tuple[Vec2, Vec2] | None, float]] = []
    for i, box in enumerate(arena.obstacles):
        if box.blocks_flight(altitude):
            found.append((obstacle_geom_name(i), box.footprint, None, 0.0))
    if ROBOT_SIZE[2] > altitude - VERTICAL_CLEARANCE:  # robots as tall as the flight
        for robot in arena.robots:
            for segment in robot.segments():
                found.append((robot_body_name(robot.marker_id), None, segment, ROBOT_RADIUS))
    return found


def _wall_distances(arena: ArenaSpec, a: Vec2, b: Vec2) -> list[Blocker]:
    x, y = arena.field.size[0], arena.field.size[1]
    xs, ys = (a[0], b[0]), (a[1], b[1])
    return [Blocker("wall_west", min(xs)), Blocker("wall_east", x - max(xs)),
            Blocker("wall_south", min(ys)), Blocker("wall_north", y - max(ys))]


def square_blockers(arena: ArenaSpec, plan: SquarePlan,
                    clearance: float = CLEARANCE) -> list[Blocker]:
    """Everything closer than ``clearance`` to ``plan``'s edges, nearest first (one entry
    per thing, at its smallest distance)."""
    nearest: dict[str, float] = {}
    things = _blockers(arena, plan.altitude)
    for a, b in plan.edges():
        for blocker in _wall_distances(arena, a, b):
            nearest[blocker.name] = min(nearest.get(blocker.name, math.inf), blocker.distance)
        for name, rect, segment, radius in things:
            if rect is not None:
                d = segment_rect_distance(a, b, rect)
            else:
                assert segment is not None
                d = segment_distance(a, b, segment[0], segment[1]) - radius
            nearest[name] = min(nearest.get(name, math.inf), d)
    close = [Blocker(n, d) for n, d in nearest.items() if d < clearance]
    return sorted(close, key=lambda blk: (blk.distance, blk.name))


def fit_square(arena: ArenaSpec, *, side: float = SQUARE_SIDE,
               altitude: float = SQUARE_ALTITUDE, min_side: float = MIN_SIDE,
               clearance: float = CLEARANCE) -> SquarePlan:
    """The largest square (side ``side`` down to ``min_side`` by :data:`SIDE_STEP`) from
    the start pad that keeps ``clearance`` from walls and obstacles at ``altitude``.

    Raises :class:`SquareDoesNotFit` with what blocks each direction."""
    if not 0.0 < min_side <= side:
        raise ValueError(f"fit_square: need 0 < min_side <= side, got {min_side}, {side}")
    ceiling = arena.field.size[2]
    start = arena.pad(arena.start_pad).center
    where = (f"from start pad {arena.start_pad} at ({start[0]:g}, {start[1]:g}) at "
             f"{altitude:g} m with {clearance:g} m clearance")
    if altitude + VERTICAL_CLEARANCE > ceiling:
        raise SquareDoesNotFit(f"the flight altitude {altitude:g} m leaves less than "
                               f"{VERTICAL_CLEARANCE:g} m under the {ceiling:g} m ceiling")
    steps = math.floor((side - min_side) / SIDE_STEP + 1e-9)
    sides = [round(side - k * SIDE_STEP, 6) for k in range(steps + 1)]
    if sides[-1] > min_side:
        sides.append(min_side)
    best: SquarePlan | None = None
    reasons: list[str] = []
    for direction in DIRECTIONS:
        for s in sides:
            plan = SquarePlan(start, s, altitude, direction)
            if not square_blockers(arena, plan, clearance):
                if best is None or s > best.side:
                    best = plan
                break
        else:
            first = square_blockers(arena, SquarePlan(start, min_side, altitude, direction),
                                    clearance)[0]
            sx, sy = ("+" if d > 0 else "-" for d in direction)
            reasons.append(f"toward {sx}x{sy}y {first.name} is {max(0.0, first.distance):.2f} m "
                           "away")
    if best is None:
        raise SquareDoesNotFit(f"no square of side {min_side:g}-{side:g} m fits {where}: "
                               + "; ".join(reasons))
    return best


__all__ = ["CLEARANCE", "MIN_SIDE", "SQUARE_ALTITUDE", "SQUARE_SIDE", "Blocker", "SquarePlan",
           "fit_square", "square_blockers"]
