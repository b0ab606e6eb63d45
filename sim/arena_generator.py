"""Seeded random contest arenas that follow the same rules as the YAML ones.

``generate_arena(seed)`` draws everything from ``numpy.random.default_rng(seed)`` in a
fixed order, so the same seed (and config) always gives the same :class:`ArenaSpec`.
Placement is rejection sampling with margins wider than the validation rules require:

1. tall obstacles (walls and pillars, flown around), then low ones (flown over), at least
   ``obstacle_gap`` apart so a drone fits between tall ones;
2. pads on free floor, ``pad_gap`` clear of obstacles and other pads; the first one is the
   start pad and must see most of the field at flight altitude (grid flood fill), every
   other pad must be reachable from it;
3. robots on short polylines whose swept corridors keep ``robot_gap`` from obstacles,
   pads and each other, with every waypoint reachable from the start pad.

A layout that cannot be completed is dropped and a new one drawn from the same generator;
the result is validated again by :class:`ArenaSpec` itself.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TypeVar

import numpy as np
import numpy.typing as npt

from runtime.errors import ParameterError
from sim.arena import (
    DEFAULT_ROBOT_SPEED,
    DEFAULT_WALL_THICKNESS,
    LOW_OBSTACLE_MAX_HEIGHT,
    PAD_IDS,
    PAD_SIZE,
    ROBOT_MARKER_IDS,
    ROBOT_RADIUS,
    TALL_OBSTACLE_MIN_HEIGHT,
    ArenaSpec,
    BoxObstacle,
    FieldSpec,
    GroundRobot,
    Lighting,
    Pad,
    Vec2,
    Vec3,
    flight_grid,
)
from sim.errors import ArenaError
from sim.geometry import FloodGrid, Rect, segment_distance, segment_rect_distance

T = TypeVar("T")
Range = tuple[float, float]

COORDINATE_STEP = 0.05  # m, every generated coordinate and size is a multiple of this


@dataclass(frozen=True)
class GeneratorConfig:
    """What a random arena holds and how much room it leaves (metres, m/s)."""

    field_size: Vec3 = (20.0, 14.0, 4.0)
    wall_thickness: float = DEFAULT_WALL_THICKNESS
    tall_obstacles: int = 5
    low_obstacles: int = 5
    pads: int = 10
    robots: int = 3
    tall_height: Range = (TALL_OBSTACLE_MIN_HEIGHT, 3.5)
    low_height: Range = (0.3, LOW_OBSTACLE_MAX_HEIGHT)
    box_side: Range = (0.6, 2.0)  # footprint sides of pillars and low boxes
    wall_length: Range = (2.0, 5.0)  # long side of wall-shaped tall obstacles
    wall_width: Range = (0.3, 0.6)  # short side of wall-shaped tall obstacles
    obstacle_gap: float = 1.2  # free floor between obstacles (> 2 x drone clearance)
    pad_gap: float = 0.5  # free floor around each pad
    robot_gap: float = 0.3  # free floor around each robot corridor
    robot_speed: float = DEFAULT_ROBOT_SPEED
    robot_segments: tuple[int, int] = (1, 3)
    robot_segment_length: Range = (1.5, 4.0)
    robot_loop_probability: float = 0.3
    points_step: int = 5
    points_max: int = 50
    min_reachable_fraction: float = 0.6  # of free cells, reachable from the start pad
    lighting: Lighting = Lighting.LIGHT
    tries_per_object: int = 300
    max_layouts: int = 50

    def __post_init__(self) -> None:
        for name in _RANGE_FIELDS:
            low, high = getattr(self, name)
            if not 0 <= low <= high:
                raise ParameterError(
                    f"GeneratorConfig.{name}: ({low}, {high}) is not 0 <= min <= max"
                )
        if not 1 <= self.pads <= len(PAD_IDS):
            raise ParameterError(f"GeneratorConfig.pads: {self.pads} is not in 1-{len(PAD_IDS)}")
        if not 0 <= self.robots <= len(ROBOT_MARKER_IDS):
            raise ParameterError(
                f"GeneratorConfig.robots: {self.robots} is not in 0-{len(ROBOT_MARKER_IDS)}"
            )
        if self.tall_height[0] < TALL_OBSTACLE_MIN_HEIGHT:
            raise ParameterError(
                f"GeneratorConfig.tall_height: {self.tall_height} starts below "
                f"{TALL_OBSTACLE_MIN_HEIGHT} m"
            )
        if self.low_height[1] > LOW_OBSTACLE_MAX_HEIGHT:
            raise ParameterError(
                f"GeneratorConfig.low_height: {self.low_height} ends above "
                f"{LOW_OBSTACLE_MAX_HEIGHT} m"
            )
        if self.robot_segments[0] < 1:
            raise ParameterError(f"GeneratorConfig.robot_segments: {self.robot_segments} < 1")
        if min(self.tries_per_object, self.max_layouts, self.points_step) < 1:
            raise ParameterError("GeneratorConfig: tries, layouts and points_step must be >= 1")


_RANGE_FIELDS = (
    "tall_height",
    "low_height",
    "box_side",
    "wall_length",
    "wall_width",
    "robot_segments",
    "robot_segment_length",
)


class _LayoutFailed(Exception):
    """This layout cannot be completed; draw another one."""


def _snap(value: float) -> float:
    return round(round(value / COORDINATE_STEP) * COORDINATE_STEP, 3)


def _uniform(rng: np.random.Generator, bounds: Range) -> float:
    return float(rng.uniform(bounds[0], bounds[1]))


def _attempt(tries: int, sample: Callable[[], T], accept: Callable[[T], bool]) -> T:
    for _ in range(tries):
        candidate = sample()
        if accept(candidate):
            return candidate
    raise _LayoutFailed


class _Layout:
    """One attempt at filling the field; raises :class:`_LayoutFailed` when stuck."""

    def __init__(self, config: GeneratorConfig, rng: np.random.Generator) -> None:
        self.config = config
        self.rng = rng
        self.field = FieldSpec(size=config.field_size, wall_thickness=config.wall_thickness)
        self.obstacles: list[BoxObstacle] = []
        self.pads: list[Pad] = []
        self.robots: list[GroundRobot] = []

    def _center(self, half: Vec2, margin: float) -> Vec2:
        sx, sy, _ = self.field.size
        return (
            _snap(float(self.rng.uniform(half[0] + margin, sx - half[0] - margin))),
            _snap(float(self.rng.uniform(half[1] + margin, sy - half[1] - margin))),
        )

    def _box(self, tall: bool) -> BoxObstacle:
        c, rng = self.config, self.rng
        if tall and rng.random() < 0.5:
            long, short = _uniform(rng, c.wall_length), _uniform(rng, c.wall_width)
            sides = (long, short) if rng.random() < 0.5 else (short, long)
        else:
            sides = (_uniform(rng, c.box_side), _uniform(rng, c.box_side))
        height = _uniform(rng, c.tall_height if tall else c.low_height)
        size = (_snap(sides[0]), _snap(sides[1]), _snap(height))
        return BoxObstacle(center=self._center((size[0] / 2, size[1] / 2), 0.0), size=size)

    def _box_fits(self, box: BoxObstacle) -> bool:
        if not self.field.footprint.contains(box.footprint):
            return False
        grown = box.footprint.inflated(self.config.obstacle_gap)
        return not any(grown.overlaps(other.footprint) for other in self.obstacles)

    def place_obstacles(self) -> None:
        c = self.config
        for tall in (True,) * c.tall_obstacles + (False,) * c.low_obstacles:
            box = _attempt(c.tries_per_object, functools.partial(self._box, tall), self._box_fits)
            self.obstacles.append(box)

    def _pad_fits(self, center: Vec2, grid: FloodGrid, reach: npt.NDArray[np.bool_]) -> bool:
        grown = Rect.centered(center, (PAD_SIZE, PAD_SIZE)).inflated(self.config.pad_gap)
        if any(grown.overlaps(b.footprint) for b in self.obstacles):
            return False
        if any(grown.overlaps(p.footprint) for p in self.pads):
            return False
        return bool(reach[grid.cell(center)])

    def place_pads(self) -> tuple[FloodGrid, npt.NDArray[np.bool_]]:
        """Place the pads; returns the flight grid and the cells reachable from the start."""
        c, rng = self.config, self.rng
        grid = flight_grid(self.field, self.obstacles)
        ids = [int(i) for i in rng.permutation(np.asarray(PAD_IDS))[: c.pads]]
        half = (PAD_SIZE / 2.0, PAD_SIZE / 2.0)

        def start_ok(center: Vec2) -> bool:
            reach = grid.reachable_from(center)
            return self._pad_fits(center, grid, reach) and (
                reach.sum() >= c.min_reachable_fraction * grid.free.sum()
            )

        start = _attempt(c.tries_per_object, lambda: self._center(half, 0.0), start_ok)
        self.pads.append(Pad(id=ids[0], center=start))
        reach = grid.reachable_from(start)
        for pad_id in ids[1:]:
            center = _attempt(
                c.tries_per_object,
                lambda: self._center(half, 0.0),
                lambda xy: self._pad_fits(xy, grid, reach),
            )
            self.pads.append(Pad(id=pad_id, center=center))
        return grid, reach

    def _path(self) -> tuple[tuple[Vec2, ...], bool]:
        c, rng = self.config, self.rng
        margin = ROBOT_RADIUS + c.robot_gap
        points = [self._center((0.0, 0.0), margin)]
        for _ in range(int(rng.integers(c.robot_segments[0], c.robot_segments[1] + 1))):
            heading = rng.uniform(0.0, 2.0 * math.pi)
            length = _uniform(rng, c.robot_segment_length)
            x, y = points[-1]
            points.append(
                (_snap(x + length * math.cos(heading)), _snap(y + length * math.sin(heading)))
            )
        loop = len(points) >= 3 and rng.random() < c.robot_loop_probability
        return tuple(points), loop

    def _robot_fits(
        self, robot: GroundRobot, grid: FloodGrid, reach: npt.NDArray[np.bool_]
    ) -> bool:
        c = self.config
        inner = self.field.footprint.inflated(-(ROBOT_RADIUS + c.robot_gap))
        if not all(inner.contains_point(w) and reach[grid.cell(w)] for w in robot.path):
            return False
        segments = list(robot.segments())
        if any(math.dist(a, b) < c.robot_segment_length[0] / 2.0 for a, b in segments):
            return False
        clear = ROBOT_RADIUS + c.robot_gap
        rects = [b.footprint for b in self.obstacles] + [p.footprint for p in self.pads]
        if any(segment_rect_distance(a, b, r) < clear for a, b in segments for r in rects):
            return False
        return not any(
            segment_distance(a, b, p, q) < 2.0 * ROBOT_RADIUS + c.robot_gap
            for other in self.robots
            for p, q in other.segments()
            for a, b in segments
        )

    def place_robots(self, grid: FloodGrid, reach: npt.NDArray[np.bool_]) -> None:
        c, rng = self.config, self.rng
        drawn = rng.choice(np.asarray(ROBOT_MARKER_IDS), size=c.robots, replace=False)
        markers = sorted(int(i) for i in drawn)
        pad_ids = sorted(p.id for p in self.pads)
        for marker in markers:
            points = tuple(
                (pad_id, int(rng.integers(1, c.points_max // c.points_step + 1)) * c.points_step)
                for pad_id in pad_ids
            )

            def sample(
                marker: int = marker, points: tuple[tuple[int, int], ...] = points
            ) -> GroundRobot:
                path, loop = self._path()
                return GroundRobot(marker, path, points, c.robot_speed, loop)

            self.robots.append(
                _attempt(c.tries_per_object, sample, lambda r: self._robot_fits(r, grid, reach))
            )

    def build(self, name: str) -> ArenaSpec:
        self.place_obstacles()
        grid, reach = self.place_pads()
        self.place_robots(grid, reach)
        return ArenaSpec(
            name=name,
            field=self.field,
            pads=tuple(sorted(self.pads, key=lambda p: p.id)),
            obstacles=tuple(self.obstacles),
            robots=tuple(self.robots),
            start_pad=self.pads[0].id,
            lighting=self.config.lighting,
        )


def generate_arena(seed: int, config: GeneratorConfig | None = None) -> ArenaSpec:
    """A random valid arena; the same ``seed`` and ``config`` always give the same spec.

    Raises :class:`ArenaError` (key ``generator``) if no layout fits within
    ``config.max_layouts`` attempts, which means the config asks for too much.
    """
    config = GeneratorConfig() if config is None else config
    rng = np.random.default_rng(seed)
    for _ in range(config.max_layouts):
        try:
            return _Layout(config, rng).build(name=f"random-{seed}")
        except _LayoutFailed:
            continue
    raise ArenaError(
        "generator",
        f"seed {seed}: nothing fitted in {config.max_layouts} layouts; "
        "ask for fewer or smaller objects, or smaller gaps",
    )
