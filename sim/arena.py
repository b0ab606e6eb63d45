"""Contest arena spec: field, walls, box obstacles, landing pads, ground robots, lighting.

Frame: the MuJoCo world is the ENU ``map`` frame (x east, y north, z up, metres) with its
origin at the south-west floor corner of the field, so the field spans
``[0, size_x] x [0, size_y] x [0, size_z]``. Walls stand just outside that box.

An :class:`ArenaSpec` validates itself when built, so an invalid arena cannot exist. Every
rule violation raises :class:`~sim.errors.ArenaError` naming the key path as written in the
arena YAML (``pads[3].center``) and the problem. :func:`load_arena` reads
``config/arenas/*.yaml`` strictly: unknown keys, missing keys, wrong types and duplicate
mapping keys are errors too.
"""

from __future__ import annotations

import bisect
import functools
import itertools
import math
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt
import yaml

from runtime.parameters import config_path, load_yaml, yaml_syntax_problem
from sim.errors import ArenaError
from sim.geometry import FloodGrid, Rect, segment_distance, segment_rect_distance

Vec2 = tuple[float, float]
Vec3 = tuple[float, float, float]

DEFAULT_ARENA = "arenas/contest.yaml"
"""The default arena, in the config folder (:func:`runtime.parameters.config_path`)."""

PAD_IDS = range(1, 11)
"""Marker IDs printed on landing pads (DICT_7X7_1000)."""
ROBOT_MARKER_IDS = range(12, 27)
"""Marker IDs carried by ground robots (DICT_7X7_1000)."""

PAD_SIZE = 1.0  # m, side of the light-blue pad square
PAD_MARKER_SIZE = 0.5  # m, side of the pad's ArUco marker, black border included
PAD_THICKNESS = 0.01  # m, the pad is a thin mat on the floor
ROBOT_SIZE: Vec3 = (0.5, 0.5, 0.25)  # m, robot body extents (length, width, height)
ROBOT_MARKER_SIZE = 0.4  # m, side of the marker on the robot's top
ROBOT_RADIUS = math.hypot(ROBOT_SIZE[0], ROBOT_SIZE[1]) / 2.0  # m, circumscribed footprint

FLIGHT_ALTITUDE = 1.5  # m, altitude at which the field must be connected
VERTICAL_CLEARANCE = 0.3  # m, an obstacle blocks flight if taller than altitude - this
DRONE_CLEARANCE = 0.4  # m, horizontal half-width of the corridor a drone needs
GRID_RESOLUTION = 0.1  # m, cell side of the reachability grid

LOW_OBSTACLE_MAX_HEIGHT = 1.0  # m, low obstacles are flown over
TALL_OBSTACLE_MIN_HEIGHT = 2.5  # m, tall obstacles are flown around

FIELD_SIZE_LIMITS: tuple[tuple[float, float], ...] = ((4.0, 60.0), (4.0, 60.0), (2.5, 10.0))
WALL_THICKNESS_LIMITS = (0.05, 1.0)  # m
OBSTACLE_MIN_SIDE = 0.05  # m
ROBOT_SPEED_LIMITS = (0.01, 1.0)  # m/s
ROBOT_MIN_SEGMENT = 0.1  # m, shortest allowed path segment
POINTS_LIMITS = (0, 1000)
DEFAULT_WALL_THICKNESS = 0.2  # m
DEFAULT_ROBOT_SPEED = 0.2  # m/s


class Lighting(Enum):
    """Lighting preset of the arena (seed 003, Table 1: light and dark conditions)."""

    LIGHT = "light"
    DARK = "dark"


@dataclass(frozen=True)
class FieldSpec:
    """The flyable box: ``size`` = (x east, y north, z ceiling) in metres, walls around it."""

    size: Vec3 = (20.0, 14.0, 4.0)
    wall_thickness: float = DEFAULT_WALL_THICKNESS

    @property
    def footprint(self) -> Rect:
        """The floor rectangle ``[0, x] x [0, y]``."""
        return Rect(0.0, 0.0, self.size[0], self.size[1])

    def describe(self) -> str:
        """``20.0 x 14.0 m``, for messages."""
        return f"{self.size[0]!r} x {self.size[1]!r} m"


@dataclass(frozen=True)
class BoxObstacle:
    """An axis-aligned box standing on the floor: ``size`` = full extents (x, y, height)."""

    center: Vec2
    size: Vec3

    @property
    def height(self) -> float:
        """Top of the box above the floor [m]."""
        return self.size[2]

    @property
    def footprint(self) -> Rect:
        """The box's floor rectangle."""
        return Rect.centered(self.center, (self.size[0], self.size[1]))

    def blocks_flight(self, altitude: float = FLIGHT_ALTITUDE) -> bool:
        """True when a drone at ``altitude`` must fly around this box rather than over it."""
        return self.height > altitude - VERTICAL_CLEARANCE


@dataclass(frozen=True)
class Pad:
    """A 1 m light-blue landing pad with ArUco marker ``id`` (1-10) centred on it.

    The marker is upright when seen from above with north (+y) at the top of the image.
    """

    id: int
    center: Vec2

    @property
    def footprint(self) -> Rect:
        """The pad's floor rectangle."""
        return Rect.centered(self.center, (PAD_SIZE, PAD_SIZE))


@dataclass(frozen=True)
class GroundRobot:
    """A slow ground robot carrying marker ``marker_id`` and the points each pad is worth.

    It drives along ``path`` at ``speed`` starting from ``path[0]`` at t = 0: back and forth
    (ping-pong) or, when ``loop`` is set, round the closed polygon. ``points`` holds
    ``(pad_id, points)`` pairs sorted by pad id; :attr:`points_table` gives them as a dict.
    """

    marker_id: int
    path: tuple[Vec2, ...]
    points: tuple[tuple[int, int], ...]
    speed: float = DEFAULT_ROBOT_SPEED
    loop: bool = False

    @property
    def points_table(self) -> dict[int, int]:
        """``{pad_id: points}``."""
        return dict(self.points)

    def segments(self) -> Iterator[tuple[Vec2, Vec2]]:
        """The path's segments in driving order for one pass (closing segment if ``loop``)."""
        yield from zip(self.path[:-1], self.path[1:], strict=True)
        if self.loop:
            yield self.path[-1], self.path[0]

    def route(self) -> Iterator[tuple[Vec2, Vec2]]:
        """The segments of one full cycle: a loop once round, a ping-pong there and back."""
        yield from self.segments()
        if not self.loop:
            for a, b in reversed(list(self.segments())):
                yield b, a

    @property
    def cycle_length(self) -> float:
        """Distance driven in one full cycle [m]."""
        return self._route_table.ends[-1]

    @functools.cached_property
    def _route_table(self) -> _RouteTable:
        """The route's segments, their lengths and where each ends along the cycle (worked
        out once: :func:`robot_pose` runs at every robot update)."""
        segments = tuple(self.route())
        lengths = tuple(math.dist(a, b) for a, b in segments)
        yaws = tuple(math.atan2(by - ay, bx - ax) for (ax, ay), (bx, by) in segments)
        return _RouteTable(segments, lengths, tuple(itertools.accumulate(lengths)), yaws)


class _RouteTable(NamedTuple):
    segments: tuple[tuple[Vec2, Vec2], ...]
    lengths: tuple[float, ...]
    ends: tuple[float, ...]
    yaws: tuple[float, ...]
    """The heading along each segment [rad]."""


class RobotPose(NamedTuple):
    """Planar pose of a ground robot: position [m] and heading (yaw from +x, CCW) [rad]."""

    xy: Vec2
    yaw: float


class StraightDrive(NamedTuple):
    """A ground robot off its route: from ``start`` at ``start_s`` [s] straight to ``end``
    at ``speed`` [m/s], then stopped there (a robot driving across the field)."""

    start_s: float
    start: Vec2
    end: Vec2
    speed: float

    def pose(self, t: float) -> RobotPose:
        """Where the robot is at ``t`` [s] (at ``start`` before ``start_s``)."""
        (ax, ay), (bx, by) = self.start, self.end
        length = math.dist(self.start, self.end)
        yaw = math.atan2(by - ay, bx - ax)
        if length == 0.0:
            return RobotPose(self.start, yaw)
        u = min(max(self.speed * (t - self.start_s) / length, 0.0), 1.0)
        return RobotPose((ax + u * (bx - ax), ay + u * (by - ay)), yaw)


def robot_pose(robot: GroundRobot, t: float) -> RobotPose:
    """Where ``robot`` is ``t`` seconds after the start, facing along its current segment."""
    segments, lengths, ends, yaws = robot._route_table
    travelled = (robot.speed * t) % ends[-1]
    index = min(bisect.bisect_right(ends, travelled), len(segments) - 1)
    (ax, ay), (bx, by) = segments[index]
    u = (travelled - (ends[index] - lengths[index])) / lengths[index]
    return RobotPose((ax + u * (bx - ax), ay + u * (by - ay)), yaws[index])  # xy, yaw


@dataclass(frozen=True)
class ArenaSpec:
    """A complete contest field; validated on construction (raises :class:`ArenaError`)."""

    name: str
    field: FieldSpec
    pads: tuple[Pad, ...]
    obstacles: tuple[BoxObstacle, ...]
    robots: tuple[GroundRobot, ...]
    start_pad: int
    lighting: Lighting = Lighting.LIGHT

    def __post_init__(self) -> None:
        validate_arena(self)

    def pad(self, pad_id: int) -> Pad:
        """The pad with marker ``pad_id``."""
        for pad in self.pads:
            if pad.id == pad_id:
                return pad
        raise KeyError(f"arena {self.name!r} has no pad {pad_id}")

    @property
    def pad_ids(self) -> tuple[int, ...]:
        """Pad marker IDs in spec order."""
        return tuple(pad.id for pad in self.pads)

    @property
    def takeoff_position(self) -> Vec3:
        """Centre of the start pad's top surface in the map frame [m]."""
        x, y = self.pad(self.start_pad).center
        return (x, y, PAD_THICKNESS)


# --------------------------------------------------------------------------- validation


def _fmt(values: Sequence[float]) -> str:
    return "(" + ", ".join(repr(round(float(v), 6)) for v in values) + ")"


def _check_range(key: str, value: float, lo: float, hi: float, unit: str = "") -> None:
    if not lo <= value <= hi:
        raise ArenaError(key, f"{value!r}{unit} is outside the allowed range [{lo!r}, {hi!r}]")


def _check_inside(key: str, what: str, rect: Rect, field: FieldSpec) -> None:
    if not field.footprint.contains(rect):
        raise ArenaError(key, f"{what} is outside the {field.describe()} field")


def _check_field(field: FieldSpec) -> None:
    for axis, (value, (lo, hi)) in enumerate(zip(field.size, FIELD_SIZE_LIMITS, strict=True)):
        _check_range(f"field.size[{axis}]", value, lo, hi, " m")
    _check_range("field.wall_thickness", field.wall_thickness, *WALL_THICKNESS_LIMITS, " m")


def _check_pads(spec: ArenaSpec) -> None:
    if not spec.pads:
        raise ArenaError("pads", "the arena needs at least one landing pad")
    seen: dict[int, int] = {}
    for i, pad in enumerate(spec.pads):
        key = f"pads[{i}]"
        if pad.id not in PAD_IDS:
            raise ArenaError(
                f"{key}.id", f"{pad.id} is not a pad marker ID ({PAD_IDS[0]}-{PAD_IDS[-1]})"
            )
        if pad.id in seen:
            raise ArenaError(f"{key}.id", f"duplicate pad ID {pad.id} (also pads[{seen[pad.id]}])")
        seen[pad.id] = i
        _check_inside(f"{key}.center", _fmt(pad.center), pad.footprint, spec.field)


def _check_obstacles(spec: ArenaSpec) -> None:
    for i, box in enumerate(spec.obstacles):
        key = f"obstacles[{i}]"
        for axis, side in enumerate(box.size):
            if side < OBSTACLE_MIN_SIDE:
                raise ArenaError(
                    f"{key}.size[{axis}]", f"{side!r} m is smaller than {OBSTACLE_MIN_SIDE} m"
                )
        if box.height > spec.field.size[2]:
            raise ArenaError(
                f"{key}.size[2]",
                f"height {box.height!r} m is above the {spec.field.size[2]!r} m ceiling",
            )
        _check_inside(f"{key}.center", f"box {_fmt(box.center)}", box.footprint, spec.field)


def _check_robots(spec: ArenaSpec) -> None:
    seen: dict[int, int] = {}
    pad_ids = set(spec.pad_ids)
    for i, robot in enumerate(spec.robots):
        key = f"robots[{i}]"
        if robot.marker_id not in ROBOT_MARKER_IDS:
            raise ArenaError(
                f"{key}.marker_id",
                f"{robot.marker_id} is not a robot marker ID "
                f"({ROBOT_MARKER_IDS[0]}-{ROBOT_MARKER_IDS[-1]})",
            )
        if robot.marker_id in seen:
            raise ArenaError(
                f"{key}.marker_id",
                f"duplicate robot marker ID {robot.marker_id} "
                f"(also robots[{seen[robot.marker_id]}])",
            )
        seen[robot.marker_id] = i
        _check_range(f"{key}.speed", robot.speed, *ROBOT_SPEED_LIMITS, " m/s")
        _check_robot_path(spec, key, robot)
        table_ids = [pad_id for pad_id, _ in robot.points]
        if table_ids != sorted(set(table_ids)):
            raise ArenaError(f"{key}.points", "pad IDs must be unique and sorted")
        for pad_id, points in robot.points:
            if pad_id not in pad_ids:
                raise ArenaError(f"{key}.points[{pad_id}]", f"the arena has no pad {pad_id}")
            _check_range(f"{key}.points[{pad_id}]", points, *POINTS_LIMITS)
        missing = sorted(pad_ids - set(table_ids))
        if missing:
            raise ArenaError(f"{key}.points", f"no points given for pads {missing}")


def _check_robot_path(spec: ArenaSpec, key: str, robot: GroundRobot) -> None:
    if len(robot.path) < 2:
        raise ArenaError(f"{key}.path", "a path needs at least 2 waypoints")
    if robot.loop and len(robot.path) < 3:
        raise ArenaError(f"{key}.loop", "a closed loop needs at least 3 waypoints")
    inner = spec.field.footprint.inflated(-ROBOT_RADIUS)
    for j, waypoint in enumerate(robot.path):
        if not inner.contains_point(waypoint):
            raise ArenaError(
                f"{key}.path[{j}]",
                f"{_fmt(waypoint)} leaves the robot (radius {ROBOT_RADIUS:.2f} m) outside "
                f"the {spec.field.describe()} field",
            )
    count = len(robot.path)
    for j, (a, b) in enumerate(robot.segments()):
        if math.dist(a, b) < ROBOT_MIN_SEGMENT:
            raise ArenaError(
                f"{key}.path[{(j + 1) % count}]",
                f"{_fmt(b)} is closer than {ROBOT_MIN_SEGMENT} m to the previous waypoint",
            )


def _robot_hits_rect(robot: GroundRobot, rect: Rect) -> bool:
    return any(segment_rect_distance(a, b, rect) < ROBOT_RADIUS for a, b in robot.segments())


def _robots_collide(first: GroundRobot, second: GroundRobot) -> bool:
    return any(
        segment_distance(a, b, c, d) < 2.0 * ROBOT_RADIUS
        for a, b in first.segments()
        for c, d in second.segments()
    )


def _check_overlaps(spec: ArenaSpec) -> None:
    for i, pad in enumerate(spec.pads):
        for j in range(i):
            if pad.footprint.overlaps(spec.pads[j].footprint):
                raise ArenaError(
                    f"pads[{i}]", f"pad {pad.id} overlaps pads[{j}] (pad {spec.pads[j].id})"
                )
    for i, box in enumerate(spec.obstacles):
        for j in range(i):
            if box.footprint.overlaps(spec.obstacles[j].footprint):
                raise ArenaError(f"obstacles[{i}]", f"box overlaps obstacles[{j}]")
        for j, pad in enumerate(spec.pads):
            if box.footprint.overlaps(pad.footprint):
                raise ArenaError(f"obstacles[{i}]", f"box overlaps pads[{j}] (pad {pad.id})")
    for i, robot in enumerate(spec.robots):
        key = f"robots[{i}].path"
        for j, pad in enumerate(spec.pads):
            if _robot_hits_rect(robot, pad.footprint):
                raise ArenaError(
                    key, f"robot {robot.marker_id} drives over pads[{j}] (pad {pad.id})"
                )
        for j, box in enumerate(spec.obstacles):
            if _robot_hits_rect(robot, box.footprint):
                raise ArenaError(key, f"robot {robot.marker_id} drives into obstacles[{j}]")
        for j in range(i):
            if _robots_collide(robot, spec.robots[j]):
                raise ArenaError(
                    key,
                    f"robot {robot.marker_id} comes within {2 * ROBOT_RADIUS:.2f} m of robots[{j}] "
                    f"(robot {spec.robots[j].marker_id})",
                )


def flight_grid(
    field: FieldSpec,
    obstacles: Sequence[BoxObstacle],
    altitude: float = FLIGHT_ALTITUDE,
    resolution: float = GRID_RESOLUTION,
    clearance: float = DRONE_CLEARANCE,
) -> FloodGrid:
    """Free space at ``altitude``: cells ``clearance`` away from walls and tall obstacles."""
    x, y = field.size[0], field.size[1]
    far = max(x, y)
    walls = (
        Rect(-far, -far, clearance, y + far),
        Rect(x - clearance, -far, x + far, y + far),
        Rect(-far, -far, x + far, clearance),
        Rect(-far, y - clearance, x + far, y + far),
    )
    boxes = (b.footprint.inflated(clearance) for b in obstacles if b.blocks_flight(altitude))
    return FloodGrid.from_rects((x, y), resolution, (*walls, *boxes))


def reachable_cells(spec: ArenaSpec, altitude: float = FLIGHT_ALTITUDE) -> npt.NDArray[np.bool_]:
    """Cells of :func:`flight_grid` a drone can reach from above the start pad."""
    grid = flight_grid(spec.field, spec.obstacles, altitude)
    return grid.reachable_from(spec.pad(spec.start_pad).center)


def _check_reachability(spec: ArenaSpec) -> None:
    grid = flight_grid(spec.field, spec.obstacles)
    start = spec.pad(spec.start_pad).center
    reach = grid.reachable_from(start)
    where = f"at the {FLIGHT_ALTITUDE} m flight altitude"
    if not reach[grid.cell(start)]:
        raise ArenaError(
            "start_pad",
            f"the drone cannot fly above pad {spec.start_pad} {where} "
            f"(closer than {DRONE_CLEARANCE} m to a wall or tall obstacle)",
        )
    for i, pad in enumerate(spec.pads):
        if not reach[grid.cell(pad.center)]:
            raise ArenaError(
                f"pads[{i}].center",
                f"pad {pad.id} cannot be reached from start pad {spec.start_pad} {where}",
            )
    for i, robot in enumerate(spec.robots):
        for j, waypoint in enumerate(robot.path):
            if not reach[grid.cell(waypoint)]:
                raise ArenaError(
                    f"robots[{i}].path[{j}]",
                    f"{_fmt(waypoint)} cannot be flown over from start pad "
                    f"{spec.start_pad} {where}",
                )


def validate_arena(spec: ArenaSpec) -> None:
    """Raise :class:`ArenaError` for the first rule ``spec`` breaks.

    Rules: field size and walls in range; pad IDs 1-10 and robot marker IDs 12-26, unique;
    everything inside the field and under the ceiling; no overlaps between pads, obstacles
    and robot corridors (a robot sweeps a disc of :data:`ROBOT_RADIUS` along its path);
    every robot's points table covers every pad; the start pad exists; every pad and every
    robot waypoint is reachable from the start pad at :data:`FLIGHT_ALTITUDE` around tall
    obstacles.
    """
    if not spec.name.strip():
        raise ArenaError("name", "must not be empty")
    _check_field(spec.field)
    _check_pads(spec)
    _check_obstacles(spec)
    _check_robots(spec)
    if spec.start_pad not in spec.pad_ids:
        raise ArenaError("start_pad", f"the arena has no pad {spec.start_pad}")
    _check_overlaps(spec)
    _check_reachability(spec)


# --------------------------------------------------------------------------- YAML


def _join(path: str, key: str) -> str:
    return f"{path}.{key}" if path else key


def _type_name(value: object) -> str:
    return "null" if value is None else type(value).__name__


def _mapping(
    value: object, path: str, required: Sequence[str], optional: Sequence[str] = ()
) -> Mapping[str, Any]:
    if not isinstance(value, dict):
        raise ArenaError(path or "<root>", f"expected a mapping, got {_type_name(value)}")
    allowed = [*required, *optional]
    for key in value:
        if key not in allowed:
            raise ArenaError(
                _join(path, str(key)), f"unknown key; allowed keys are {', '.join(allowed)}"
            )
    for key in required:
        if key not in value:
            raise ArenaError(_join(path, key), "missing required key")
    return value


def _float(value: object, path: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ArenaError(path, f"expected a number, got {_type_name(value)} {value!r}")
    if not math.isfinite(value):
        raise ArenaError(path, f"expected a finite number, got {value!r}")
    return float(value)


def _int(value: object, path: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise ArenaError(path, f"expected an integer, got {_type_name(value)} {value!r}")
    return value


def _list(value: object, path: str) -> list[Any]:
    if not isinstance(value, list):
        raise ArenaError(path, f"expected a list, got {_type_name(value)}")
    return value


def _vec(value: object, path: str, n: int) -> tuple[float, ...]:
    items = _list(value, path)
    if len(items) != n:
        raise ArenaError(path, f"expected {n} numbers, got {len(items)}")
    return tuple(_float(v, f"{path}[{i}]") for i, v in enumerate(items))


def _vec2(value: object, path: str) -> Vec2:
    x, y = _vec(value, path, 2)
    return (x, y)


def _vec3(value: object, path: str) -> Vec3:
    x, y, z = _vec(value, path, 3)
    return (x, y, z)


def _parse_field(value: object) -> FieldSpec:
    data = _mapping(value, "field", ["size"], ["wall_thickness"])
    return FieldSpec(
        size=_vec3(data["size"], "field.size"),
        wall_thickness=_float(
            data.get("wall_thickness", DEFAULT_WALL_THICKNESS), "field.wall_thickness"
        ),
    )


def _parse_pad(value: object, path: str) -> Pad:
    data = _mapping(value, path, ["id", "center"])
    return Pad(id=_int(data["id"], f"{path}.id"), center=_vec2(data["center"], f"{path}.center"))


def _parse_obstacle(value: object, path: str) -> BoxObstacle:
    data = _mapping(value, path, ["center", "size"])
    return BoxObstacle(
        center=_vec2(data["center"], f"{path}.center"), size=_vec3(data["size"], f"{path}.size")
    )


def _parse_robot(value: object, path: str) -> GroundRobot:
    data = _mapping(value, path, ["marker_id", "path", "points"], ["speed", "loop"])
    waypoints = tuple(
        _vec2(w, f"{path}.path[{j}]") for j, w in enumerate(_list(data["path"], f"{path}.path"))
    )
    table = data["points"]
    if not isinstance(table, dict):
        raise ArenaError(f"{path}.points", f"expected a mapping pad_id: points, got {table!r}")
    points = tuple(
        sorted(
            (_int(pad_id, f"{path}.points[{pad_id}]"), _int(p, f"{path}.points[{pad_id}]"))
            for pad_id, p in table.items()
        )
    )
    loop = data.get("loop", False)
    if not isinstance(loop, bool):
        raise ArenaError(f"{path}.loop", f"expected true or false, got {loop!r}")
    return GroundRobot(
        marker_id=_int(data["marker_id"], f"{path}.marker_id"),
        path=waypoints,
        points=points,
        speed=_float(data.get("speed", DEFAULT_ROBOT_SPEED), f"{path}.speed"),
        loop=loop,
    )


def arena_from_dict(data: object) -> ArenaSpec:
    """Build and validate an arena from parsed YAML; raises :class:`ArenaError`."""
    top = _mapping(
        data, "", ["name", "field", "pads", "start_pad"], ["obstacles", "robots", "lighting"]
    )
    name = top["name"]
    if not isinstance(name, str):
        raise ArenaError("name", f"expected a string, got {_type_name(name)}")
    lighting = top.get("lighting", Lighting.LIGHT.value)
    try:
        preset = Lighting(lighting)
    except ValueError:
        allowed = ", ".join(item.value for item in Lighting)
        raise ArenaError("lighting", f"{lighting!r} is not one of {allowed}") from None
    return ArenaSpec(
        name=name,
        field=_parse_field(top["field"]),
        pads=tuple(_parse_pad(p, f"pads[{i}]") for i, p in enumerate(_list(top["pads"], "pads"))),
        obstacles=tuple(
            _parse_obstacle(o, f"obstacles[{i}]")
            for i, o in enumerate(_list(top.get("obstacles", []), "obstacles"))
        ),
        robots=tuple(
            _parse_robot(r, f"robots[{i}]")
            for i, r in enumerate(_list(top.get("robots", []), "robots"))
        ),
        start_pad=_int(top["start_pad"], "start_pad"),
        lighting=preset,
    )


def arena_from_yaml(text: str) -> ArenaSpec:
    """Parse arena YAML text strictly and validate it; raises :class:`ArenaError`."""
    try:
        data = load_yaml(text)
    except yaml.YAMLError as exc:
        raise ArenaError("", yaml_syntax_problem(exc)) from None
    return arena_from_dict(data)


def load_arena(path: str | Path | None = None) -> ArenaSpec:
    """Load and validate an arena YAML file (default: :data:`DEFAULT_ARENA` in the config
    folder); errors name the file and the key."""
    path = Path(path) if path is not None else config_path(DEFAULT_ARENA)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ArenaError("", f"cannot read arena file: {exc.strerror}", str(path)) from None
    try:
        return arena_from_yaml(text)
    except ArenaError as exc:
        raise exc.with_source(str(path)) from None


def default_arena() -> ArenaSpec:
    """The contest-like default field, ``config/arenas/contest.yaml``."""
    return load_arena()


def arena_to_dict(spec: ArenaSpec) -> dict[str, Any]:
    """The YAML structure of ``spec``; :func:`arena_from_dict` turns it back into ``spec``."""
    return {
        "name": spec.name,
        "lighting": spec.lighting.value,
        "field": {"size": list(spec.field.size), "wall_thickness": spec.field.wall_thickness},
        "start_pad": spec.start_pad,
        "obstacles": [{"center": list(b.center), "size": list(b.size)} for b in spec.obstacles],
        "pads": [{"id": p.id, "center": list(p.center)} for p in spec.pads],
        "robots": [
            {
                "marker_id": r.marker_id,
                "speed": r.speed,
                "loop": r.loop,
                "path": [list(w) for w in r.path],
                "points": dict(r.points),
            }
            for r in spec.robots
        ],
    }


def dump_arena(spec: ArenaSpec) -> str:
    """``spec`` as arena YAML text (block style, keys in spec order)."""
    return yaml.safe_dump(arena_to_dict(spec), sort_keys=False, default_flow_style=None)
