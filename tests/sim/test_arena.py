"""Arena spec: the default contest field, strict YAML validation, robot motion."""

from __future__ import annotations

import copy
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from runtime.parameters import config_path
from sim.arena import (
    DEFAULT_ARENA,
    FLIGHT_ALTITUDE,
    LOW_OBSTACLE_MAX_HEIGHT,
    PAD_IDS,
    ROBOT_MARKER_IDS,
    TALL_OBSTACLE_MIN_HEIGHT,
    ArenaSpec,
    Lighting,
    arena_from_dict,
    arena_from_yaml,
    dump_arena,
    load_arena,
    robot_pose,
)
from sim.errors import ArenaError
from tests.sim.footprints import overlapping_pairs


def _raw() -> dict[str, Any]:
    data: dict[str, Any] = yaml.safe_load(config_path(DEFAULT_ARENA).read_text())
    return data


def test_default_arena_is_contest_like(arena: ArenaSpec) -> None:
    assert arena.field.size == (20.0, 14.0, 4.0)
    assert sorted(arena.pad_ids) == list(PAD_IDS), "10 pads with markers 1-10"
    assert len(arena.robots) == 3
    assert all(r.marker_id in ROBOT_MARKER_IDS for r in arena.robots)
    heights = [box.height for box in arena.obstacles]
    assert any(h >= TALL_OBSTACLE_MIN_HEIGHT for h in heights), "some obstacles to fly around"
    assert any(h <= LOW_OBSTACLE_MAX_HEIGHT for h in heights), "some obstacles to fly over"
    assert all(0.1 <= r.speed <= 0.3 for r in arena.robots), "robots move slowly"
    assert arena.takeoff_position[:2] == arena.pad(arena.start_pad).center
    assert arena.lighting is Lighting.LIGHT


def test_default_arena_has_no_overlaps(arena: ArenaSpec) -> None:
    assert overlapping_pairs(arena) == []


def test_yaml_round_trip_gives_the_same_spec(arena: ArenaSpec) -> None:
    assert arena_from_yaml(dump_arena(arena)) == arena


def test_robot_drives_its_path_at_its_speed(arena: ArenaSpec) -> None:
    robot = arena.robots[0]  # ping-pong along (1.5, 3.5) -> (3.5, 3.5) -> (3.5, 5.0)
    assert robot_pose(robot, 0.0).xy == robot.path[0]
    xy, yaw = robot_pose(robot, 5.0)
    assert xy == pytest.approx((1.5 + 5.0 * robot.speed, 3.5))
    assert yaw == pytest.approx(0.0)
    assert robot_pose(robot, 12.0).xy == pytest.approx((3.5, 3.5 + 2.0 * robot.speed))
    half_cycle = robot.cycle_length / 2.0 / robot.speed
    back_xy, back_yaw = robot_pose(robot, half_cycle + 1.0)
    assert back_xy == pytest.approx((3.5, 5.0 - robot.speed)), "turns back at the end"
    assert back_yaw == pytest.approx(-math.pi / 2)
    assert robot_pose(robot, 2 * half_cycle + 5.0).xy == pytest.approx(xy), "periodic"


def test_looping_robot_goes_round_its_polygon(arena: ArenaSpec) -> None:
    robot = next(r for r in arena.robots if r.loop)
    period = robot.cycle_length / robot.speed
    samples = np.array([robot_pose(robot, t).xy for t in np.linspace(0.0, period, 200)])
    steps = np.linalg.norm(np.diff(samples, axis=0), axis=1)
    assert steps.max() <= robot.speed * period / 199 + 1e-9, "no jumps"
    assert robot_pose(robot, period).xy == pytest.approx(robot.path[0])


def _set(path: str, value: Any) -> Callable[[dict[str, Any]], None]:
    def mutate(data: dict[str, Any]) -> None:
        *parents, last = path.split(".")
        node: Any = data
        for part in parents:
            node = node[int(part)] if part.isdigit() else node[part]
        node[int(last) if last.isdigit() else last] = value

    return mutate


def _delete(path: str) -> Callable[[dict[str, Any]], None]:
    def mutate(data: dict[str, Any]) -> None:
        *parents, last = path.split(".")
        node: Any = data
        for part in parents:
            node = node[int(part)] if part.isdigit() else node[part]
        del node[last]

    return mutate


def _add_obstacle(center: list[float], size: list[float]) -> Callable[[dict[str, Any]], None]:
    def mutate(data: dict[str, Any]) -> None:
        data["obstacles"].append({"center": center, "size": size})

    return mutate


INVALID_CASES = [
    pytest.param(_set("pad", []), "pad", "unknown key", id="unknown-top-level-key"),
    pytest.param(_set("pads.2.colour", "red"), "pads[2].colour", "unknown key", id="unknown-key"),
    pytest.param(_delete("field.size"), "field.size", "missing required key", id="missing-key"),
    pytest.param(_set("field.size", "big"), "field.size", "expected a list", id="wrong-type"),
    pytest.param(
        _set("field.size", [20.0, "14", 4.0]), "field.size[1]", "expected a number", id="str"
    ),
    pytest.param(_set("pads.0.id", True), "pads[0].id", "expected an integer", id="bool-as-int"),
    pytest.param(
        _set("field.size", [20.0, 14.0, 40.0]),
        "field.size[2]",
        "outside the allowed range",
        id="field-too-tall",
    ),
    pytest.param(
        _set("pads.3.center", [21.0, 2.0]),
        "pads[3].center",
        "(21.0, 2.0) is outside the 20.0 x 14.0 m field",
        id="pad-outside-field",
    ),
    pytest.param(
        _set("pads.0.id", 11), "pads[0].id", "11 is not a pad marker ID (1-10)", id="pad-id-range"
    ),
    pytest.param(_set("pads.4.id", 2), "pads[4].id", "duplicate pad ID 2", id="duplicate-pad"),
    pytest.param(
        _set("robots.1.marker_id", 5),
        "robots[1].marker_id",
        "5 is not a robot marker ID (12-26)",
        id="robot-marker-range",
    ),
    pytest.param(
        _set("robots.1.marker_id", 14),
        "robots[1].marker_id",
        "duplicate robot marker ID 14",
        id="duplicate-robot-marker",
    ),
    pytest.param(
        _set("pads.1.center", [1.5, 2.2]), "pads[1]", "overlaps pads[0]", id="pads-overlap"
    ),
    pytest.param(
        _set("pads.2.center", [5.5, 9.0]),
        "obstacles[0]",
        "overlaps pads[2] (pad 3)",
        id="pad-on-obstacle",
    ),
    pytest.param(
        _add_obstacle([9.5, 5.0], [1.0, 1.0, 1.0]),
        "obstacles[10]",
        "overlaps obstacles[1]",
        id="obstacles-overlap",
    ),
    pytest.param(
        _set("obstacles.2.size", [4.0, 0.4, 5.0]),
        "obstacles[2].size[2]",
        "above the 4.0 m ceiling",
        id="obstacle-above-ceiling",
    ),
    pytest.param(
        _set("obstacles.4.center", [19.8, 2.5]),
        "obstacles[4].center",
        "outside the",
        id="obstacle-outside-field",
    ),
    pytest.param(
        _set("robots.0.speed", 5.0),
        "robots[0].speed",
        "outside the allowed range",
        id="robot-too-fast",
    ),
    pytest.param(
        _set("robots.0.path", [[1.5, 3.5], [9.5, 3.5]]),
        "robots[0].path",
        "drives into obstacles[1]",
        id="robot-into-obstacle",
    ),
    pytest.param(
        _set("robots.0.path", [[1.5, 3.5]]),
        "robots[0].path",
        "at least 2 waypoints",
        id="robot-single-waypoint",
    ),
    pytest.param(
        _set("robots.1.path", [[11.5, 9.0], [11.5, 6.0]]),
        "robots[1].path",
        "drives over pads[4] (pad 5)",
        id="robot-over-pad",
    ),
    pytest.param(
        _set("robots.0.points", {1: 10}),
        "robots[0].points",
        "no points given for pads [2,",
        id="points-missing-pads",
    ),
    pytest.param(
        _set("robots.0.points.42", 10),
        "robots[0].points[42]",
        "the arena has no pad 42",
        id="points-unknown-pad",
    ),
    pytest.param(_set("start_pad", 12), "start_pad", "no pad 12", id="unknown-start-pad"),
    pytest.param(_set("lighting", "dim"), "lighting", "not one of light, dark", id="lighting"),
    pytest.param(
        _add_obstacle([17.85, 7.0], [0.1, 14.0, 3.0]),
        "pads[7].center",
        "pad 8 cannot be reached from start pad 1",
        id="pads-walled-off",
    ),
]


@pytest.mark.parametrize(("mutate", "key", "problem"), INVALID_CASES)
def test_invalid_arena_names_the_key(
    mutate: Callable[[dict[str, Any]], None], key: str, problem: str
) -> None:
    data = copy.deepcopy(_raw())
    mutate(data)
    with pytest.raises(ArenaError) as caught:
        arena_from_dict(data)
    assert caught.value.key == key, str(caught.value)
    assert problem in caught.value.problem, str(caught.value)
    assert str(caught.value).startswith(f"{key}: ")


def test_low_obstacles_do_not_wall_off_the_field() -> None:
    data = copy.deepcopy(_raw())
    _add_obstacle([17.85, 7.0], [0.1, 14.0, FLIGHT_ALTITUDE - 0.5])(data)
    arena_from_dict(data)  # a drone at flight altitude passes over it


def test_duplicate_yaml_keys_are_rejected() -> None:
    text = config_path(DEFAULT_ARENA).read_text().replace("start_pad: 1",
                                                          "start_pad: 1\nstart_pad: 2")
    with pytest.raises(ArenaError,
                       match=r"invalid YAML at line \d+, column 1: duplicate key 'start_pad'"):
        arena_from_yaml(text)


def test_broken_yaml_is_an_arena_error() -> None:
    with pytest.raises(ArenaError, match="invalid YAML"):
        arena_from_yaml("pads: [1, 2\nname: x")


def test_a_yaml_syntax_error_is_one_line_naming_the_file(tmp_path: Path) -> None:
    path = tmp_path / "broken.yaml"
    path.write_text("name: x\npads: [1, 2\nfield: {}\n")
    with pytest.raises(ArenaError) as caught:
        load_arena(path)
    message = str(caught.value)
    assert "\n" not in message
    assert message.startswith(f"{path}: invalid YAML at line 3, column 6: ")


def test_file_errors_name_the_file_and_the_key(tmp_path: Path) -> None:
    data = _raw()
    data["pads"][3]["center"] = [21.0, 2.0]
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ArenaError) as caught:
        load_arena(path)
    assert str(caught.value) == (
        f"{path}: pads[3].center: (21.0, 2.0) is outside the 20.0 x 14.0 m field"
    )
    with pytest.raises(ArenaError, match="cannot read arena file"):
        load_arena(tmp_path / "missing.yaml")
