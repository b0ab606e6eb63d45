"""Seeded random arenas: reproducible, valid, no overlaps, everything reachable."""

from __future__ import annotations

import pytest

from runtime.errors import ParameterError
from sim.arena import (
    LOW_OBSTACLE_MAX_HEIGHT,
    PAD_IDS,
    ROBOT_MARKER_IDS,
    TALL_OBSTACLE_MIN_HEIGHT,
    ArenaSpec,
    arena_from_yaml,
    dump_arena,
    reachable_cells,
)
from sim.arena_generator import GeneratorConfig, generate_arena
from sim.errors import ArenaError
from tests.sim.footprints import overlapping_pairs

SEEDS = range(20)


@pytest.fixture(scope="module")
def arenas() -> dict[int, ArenaSpec]:
    return {seed: generate_arena(seed) for seed in SEEDS}


def test_same_seed_gives_an_identical_spec(arenas: dict[int, ArenaSpec]) -> None:
    for seed in (0, 7, 19):
        assert generate_arena(seed) == arenas[seed]
    assert len({dump_arena(a) for a in arenas.values()}) == len(SEEDS), "seeds differ"


@pytest.mark.parametrize("seed", SEEDS)
def test_random_arena_follows_the_contest_rules(arenas: dict[int, ArenaSpec], seed: int) -> None:
    arena = arenas[seed]
    assert sorted(arena.pad_ids) == list(PAD_IDS)
    assert len(arena.robots) == 3
    assert all(r.marker_id in ROBOT_MARKER_IDS for r in arena.robots)
    heights = [b.height for b in arena.obstacles]
    assert sum(h >= TALL_OBSTACLE_MIN_HEIGHT for h in heights) == 5
    assert sum(h <= LOW_OBSTACLE_MAX_HEIGHT for h in heights) == 5
    assert overlapping_pairs(arena) == []
    assert arena_from_yaml(dump_arena(arena)) == arena, "a generated arena can be saved"


def test_start_pad_sees_most_of_the_field(arenas: dict[int, ArenaSpec]) -> None:
    for arena in arenas.values():
        reach = reachable_cells(arena)
        assert reach.mean() > 0.5, f"{arena.name}: only {reach.mean():.0%} of the field reachable"


def test_config_changes_what_is_generated() -> None:
    sparse = generate_arena(3, GeneratorConfig(tall_obstacles=1, low_obstacles=0, pads=4, robots=1))
    assert (len(sparse.obstacles), len(sparse.pads), len(sparse.robots)) == (1, 4, 1)


def test_impossible_config_fails_with_an_arena_error() -> None:
    crowded = GeneratorConfig(
        field_size=(6.0, 6.0, 4.0), tall_obstacles=8, tries_per_object=20, max_layouts=3
    )
    with pytest.raises(ArenaError, match="generator: seed 1: nothing fitted in 3 layouts"):
        generate_arena(1, crowded)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"pads": 11}, "GeneratorConfig.pads"),
        ({"tall_height": (2.0, 3.0)}, "GeneratorConfig.tall_height"),
        ({"low_height": (0.5, 1.5)}, "GeneratorConfig.low_height"),
        ({"box_side": (2.0, 1.0)}, "GeneratorConfig.box_side"),
    ],
)
def test_bad_config_names_the_field(kwargs: dict[str, object], field: str) -> None:
    with pytest.raises(ParameterError, match=field):
        GeneratorConfig(**kwargs)  # type: ignore[arg-type]
