"""What every scenario takes (:class:`ScenarioOptions`) and what it is: a function of them
that writes ``report.json`` and returns the report."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from quadmission.errors import OptionsError
from sim.arena import ArenaSpec, Lighting, default_arena, dump_arena, load_arena
from sim.arena_generator import generate_arena
from sim.fault_spec import Fault

__all__ = ["ARENA_NAME", "Scenario", "ScenarioOptions"]

ARENA_NAME = "arena.yaml"  # every run writes the arena it flew here


@dataclass(frozen=True)
class ScenarioOptions:
    """What every scenario takes: where to write, the seed, the arena, and where progress
    lines go (default: nowhere)."""

    out: Path
    seed: int = 0
    arena: Path | None = None  # None: config/arenas/contest.yaml
    random_arena: bool = False  # generate an arena from the seed instead
    lighting: Lighting | None = None  # None: the arena file's preset
    target_robot: int | None = None  # mission: the robot to find (None: config/mission.yaml)
    remove_pad: int | None = None  # mission: take this pad out of the field (seed 003, 4.2)
    faults: tuple[Fault, ...] = ()  # mission: faults injected (sim.fault_spec, issue 22)
    progress: Callable[[str], None] = field(default=lambda _line: None, compare=False)
    # pacing, recording, Foxglove, the operator page (quadmission.assembly.services.RunServices)
    services: Any = field(default=None, compare=False)

    def __post_init__(self) -> None:
        if self.random_arena and self.arena is not None:
            raise OptionsError(f"give an arena file ({self.arena}) or a random arena, not both")

    def load_arena(self) -> ArenaSpec:
        """The arena this run flies, with the lighting option applied. It is also written
        to ``out/arena.yaml``, so anyone can replay the run or recompute its errors."""
        if self.random_arena:
            arena = generate_arena(self.seed)
        else:
            arena = load_arena(self.arena) if self.arena else default_arena()
        if self.lighting is not None:
            arena = replace(arena, lighting=self.lighting)
        self.out.mkdir(parents=True, exist_ok=True)
        (self.out / ARENA_NAME).write_text(dump_arena(arena))
        return arena


Scenario = Callable[[ScenarioOptions], dict[str, Any]]
