"""A campaign file, validated, and the cells it expands to (pure: PyYAML, no Dask).

A campaign is a list of matrix blocks; each block's cells are the product of its
scenarios x seeds x lighting x fault sets, in that order (the fault sets vary fastest, so
``--limit`` takes a bit of each fault first)::

    name: faults               # optional (default: the file's stem)
    timeout_s: 3600            # optional: a run still going after this is stopped
    matrix:
      - scenarios: [mission]   # a name or a list (quadmission.scenarios.SCENARIOS)
        seeds: 1-3             # a list of ints, or FIRST-LAST
        arena: random          # random (the default: generated from the seed) or a YAML
        lighting: [light, dark]  # light, dark, arena (the arena's own; the default)
        faults:                # one entry per run: a spec, a list of specs, [] clean
          - vio_stop@40:3
          - [battery_low@60, wind_gust@70:2,force=3]
      - scenarios: mission
        seeds: 200-229
        draw_faults:           # instead of faults: each run's faults drawn from its seed
          count: 1-2
          window_s: [3, 450]
          kinds: {vio_stop: {duration_s: [1, 5]}, link_lost: {duration_s: [0.5, 3]}}

A block with ``draw_faults`` (:mod:`.draw`) gives each of its runs one fault set drawn
from a generator seeded by the run: its ``draw_faults`` as written, arena, scenario, seed
and lighting. The same file always gives the same runs (and a longer seed range the runs
there were, so a campaign grows and resumes); another draw, arena or lighting other ones.
The drawn faults are explicit specs in the cell, so its key, row and replay line carry
them.

A cell is one ``quadmission sim`` run: :meth:`Cell.sim_args` is its command line, and
:meth:`Cell.replay_command` the one line a person types to fly it again (same seed, same
run). Every error names the file, the key and the bad value
(:class:`~quadmission.errors.CampaignError`).
"""

from __future__ import annotations

import hashlib
import re
import shlex
from collections.abc import Collection, Iterable, Mapping
from dataclasses import dataclass
from itertools import product
from pathlib import Path
from typing import Any

import yaml

from quadmission.campaigns.draw import FaultDraw, parse_draw, run_rng
from quadmission.errors import CampaignError
from sim.arena import Lighting
from sim.fault_spec import Fault, FaultKind, FaultSpecError, parse_fault

__all__ = ["ARENA_LIGHTING", "DEFAULT_TIMEOUT_S", "RANDOM_ARENA", "Campaign", "Cell",
           "load_campaign", "parse_campaign"]

RANDOM_ARENA = "random"  # arena: a random arena generated from the seed
ARENA_LIGHTING = "arena"  # lighting: the arena's own preset
DEFAULT_TIMEOUT_S = 3600.0  # s of wall time a run may take before it is stopped
TOP_KEYS = frozenset({"name", "timeout_s", "matrix"})
BLOCK_KEYS = frozenset({"scenarios", "seeds", "arena", "lighting", "faults", "draw_faults"})
MAX_KEY_CHARS = 100  # a cell's folder name is cut (and a hash added) past this


@dataclass(frozen=True)
class Cell:
    """One run of a campaign: a scenario in an arena, with a seed, a lighting and faults.
    ``arena`` None: a random arena from the seed; ``lighting`` None: the arena's own."""

    scenario: str
    seed: int
    arena: Path | None = None
    lighting: Lighting | None = None
    faults: tuple[Fault, ...] = ()

    @property
    def fault_specs(self) -> tuple[str, ...]:
        return tuple(f.spec() for f in self.faults)

    @property
    def lighting_name(self) -> str:
        return ARENA_LIGHTING if self.lighting is None else self.lighting.value

    @property
    def key(self) -> str:
        """A stable, unique name for the cell, fit for a folder name; the same cell gets
        the same key in every campaign (resuming relies on it). Readable when it can be;
        else cut, with a hash of the whole cell added."""
        arena = f"random{self.seed}" if self.arena is None else f"{self.arena.stem}-s{self.seed}"
        text = (f"{self.scenario}_{arena}_{self.lighting_name}_"
                f"{'+'.join(self.fault_specs) or 'clean'}")
        safe = re.sub(r"[^A-Za-z0-9_.,:=@+-]+", "-", text)
        if safe == text and len(text) <= MAX_KEY_CHARS:
            return text
        whole = "|".join((self.scenario, str(self.seed), str(self.arena or RANDOM_ARENA),
                          self.lighting_name, *self.fault_specs))
        return f"{safe[:MAX_KEY_CHARS - 11]}-{hashlib.sha1(whole.encode()).hexdigest()[:10]}"

    def sim_args(self, out: Path) -> list[str]:
        """The ``quadmission`` arguments that fly this cell into ``out``."""
        args = ["sim", "--scenario", self.scenario, "--seed", str(self.seed)]
        args += ["--random-arena"] if self.arena is None else ["--arena", str(self.arena)]
        if self.lighting is not None:
            args += ["--lighting", self.lighting.value]
        for spec in self.fault_specs:
            args += ["--fault", spec]
        return [*args, "--out", str(out)]

    def replay_command(self, out: Path) -> str:
        """The one-line shell command that flies this cell again into ``out``."""
        return shlex.join(["quadmission", *self.sim_args(out)])


@dataclass(frozen=True)
class Campaign:
    """A validated campaign: its name, its cells in order, each run's wall-time limit."""

    name: str
    cells: tuple[Cell, ...]
    timeout_s: float = DEFAULT_TIMEOUT_S

    def limited(self, limit: int | None) -> Campaign:
        """The first ``limit`` cells (all of them for None)."""
        if limit is None:
            return self
        if limit < 1:
            raise CampaignError(f"--limit {limit}: must be at least 1")
        return Campaign(self.name, self.cells[:limit], self.timeout_s)


def _as_list(value: Any) -> list[Any]:
    return list(value) if isinstance(value, list | tuple) else [value]


def _seeds(value: Any, where: str) -> list[int]:
    if isinstance(value, str):
        match = re.fullmatch(r"\s*(\d+)\s*-\s*(\d+)\s*", value)
        if match is None:
            raise CampaignError(f"{where}: {value!r} is not a list of seeds or FIRST-LAST "
                                "(e.g. 100-149)")
        first, last = int(match[1]), int(match[2])
        if last < first:
            raise CampaignError(f"{where}: {value!r} ends before it starts")
        return list(range(first, last + 1))
    seeds = _as_list(value)
    if not seeds:
        raise CampaignError(f"{where}: no seeds")
    for seed in seeds:
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            raise CampaignError(f"{where}: {seed!r} is not a seed (an integer >= 0)")
    return seeds


def _lighting(value: Any, where: str) -> list[Lighting | None]:
    names = [ARENA_LIGHTING, *(preset.value for preset in Lighting)]
    out: list[Lighting | None] = []
    for item in _as_list(value):
        if item not in names:
            raise CampaignError(f"{where}: {item!r} is not a lighting (allowed: "
                                f"{', '.join(names)})")
        out.append(None if item == ARENA_LIGHTING else Lighting(item))
    if not out:
        raise CampaignError(f"{where}: no lighting")
    return out


def _fault_sets(value: Any, where: str) -> list[tuple[Fault, ...]]:
    sets: list[tuple[Fault, ...]] = []
    for i, entry in enumerate(_as_list(value)):
        specs = _as_list(entry) if entry is not None else []
        faults = []
        for j, spec in enumerate(specs):
            at = f"{where}[{i}]" + (f"[{j}]" if isinstance(entry, list) else "")
            if not isinstance(spec, str):
                raise CampaignError(f"{at}: {spec!r} is not a fault spec "
                                    "(KIND@T[:DURATION][,key=value...])")
            try:
                faults.append(parse_fault(spec))
            except FaultSpecError as exc:
                hint = ("; in a [flow, list] YAML splits at commas: quote the spec"
                        if "@" not in spec and "=" in spec else "")
                raise CampaignError(f"{at}: {exc}{hint}") from None
        sets.append(tuple(faults))
    if not sets:
        raise CampaignError(f"{where}: no fault sets (write [[]] for clean runs)")
    return sets


def _arena(value: Any, where: str, base: Path) -> Path | None:
    if value == RANDOM_ARENA:
        return None
    if not isinstance(value, str):
        raise CampaignError(f"{where}: {value!r} is not {RANDOM_ARENA!r} or an arena YAML")
    path = Path(value)
    for candidate in (path, base / path):  # as given (from the working folder), or beside
        if candidate.is_file():  # the campaign file; absolute, for workers elsewhere
            return candidate.resolve()
    raise CampaignError(f"{where}: no arena file {value!r} (nor {base / path})")


def _check_keys(data: Any, keys: frozenset[str], where: str) -> None:
    """``data`` is a mapping of ``keys`` only."""
    allowed = ", ".join(sorted(keys))
    if not isinstance(data, Mapping):
        raise CampaignError(f"{where}: expected a mapping with keys {allowed}, got {data!r}")
    unknown = sorted(set(data) - keys)
    if unknown:
        raise CampaignError(f"{where}: unknown key {unknown[0]!r} (allowed: {allowed})")


def _block_cells(block: Any, where: str, *, scenarios: Collection[str],
                 faulted: Mapping[str, Collection[FaultKind]], base: Path,
                 node_names: Collection[str] | None = None) -> list[Cell]:
    _check_keys(block, BLOCK_KEYS, where)
    for required in ("scenarios", "seeds"):
        if required not in block:
            raise CampaignError(f"{where}: missing {required!r}")
    names = _as_list(block["scenarios"])
    for name in names:
        if name not in scenarios:
            raise CampaignError(f"{where}.scenarios: unknown scenario {name!r} (known: "
                                f"{', '.join(sorted(scenarios))})")
    if not names:
        raise CampaignError(f"{where}.scenarios: no scenario")
    seeds = _seeds(block["seeds"], f"{where}.seeds")
    arena = _arena(block.get("arena", RANDOM_ARENA), f"{where}.arena", base)
    lighting = _lighting(block.get("lighting", ARENA_LIGHTING), f"{where}.lighting")
    draw: FaultDraw | None = None
    if "draw_faults" in block:
        if "faults" in block:
            raise CampaignError(f"{where}: faults and draw_faults together (a block lists "
                                "its faults or draws them, not both)")
        draw = parse_draw(block["draw_faults"], f"{where}.draw_faults", node_names=node_names)
        kinds = {k.kind for k in draw.kinds}
        field = "draw_faults.kinds"
    else:
        fault_sets = _fault_sets(block.get("faults", [[]]), f"{where}.faults")
        kinds = {f.kind for fs in fault_sets for f in fs}
        field = "faults"
    for name in names:
        takes = faulted.get(name, ())
        if not takes and kinds:
            raise CampaignError(f"{where}.{field}: scenario {name!r} takes no faults (those "
                                f"that do: {', '.join(sorted(faulted))})")
        cannot = sorted(k.value for k in kinds - set(takes))
        if cannot:
            raise CampaignError(
                f"{where}.{field}: scenario {name!r} cannot take {cannot[0]} "
                f"(it takes: {', '.join(sorted(k.value for k in takes))})")
    if draw is not None:
        # seeded by what makes the run (the draw as written, the arena, scenario, seed and
        # lighting): the same file, the same runs; more seeds keep the runs there were
        return [Cell(name, seed, arena, light, draw.draw(run_rng(
                    block["draw_faults"], block.get("arena", RANDOM_ARENA), name, seed,
                    ARENA_LIGHTING if light is None else light.value)))
                for name, seed, light in product(names, seeds, lighting)]
    return [Cell(name, seed, arena, light, faults)
            for name, seed, light, faults in product(names, seeds, lighting, fault_sets)]


def parse_campaign(data: Any, where: str, *, scenarios: Collection[str],
                   faulted: Mapping[str, Collection[FaultKind]], base: Path = Path("."),
                   default_name: str = "campaign",
                   node_names: Collection[str] | None = None) -> Campaign:
    """A campaign from its parsed YAML. ``where`` prefixes every error (the file);
    ``scenarios``: the names that exist; ``faulted``: those that take faults, with the
    kinds each takes; ``base``: the folder arena paths may be relative to;
    ``node_names``: the nodes a drawn ``node_stop`` may name (None: checked by the run)."""
    _check_keys(data, TOP_KEYS, where)
    name = data.get("name", default_name)
    if not isinstance(name, str) or not name.strip():
        raise CampaignError(f"{where}: name: {name!r} is not a name")
    timeout = data.get("timeout_s", DEFAULT_TIMEOUT_S)
    if isinstance(timeout, bool) or not isinstance(timeout, int | float) or not timeout > 0:
        raise CampaignError(f"{where}: timeout_s: {timeout!r} is not a positive number of "
                            "seconds")
    blocks = data.get("matrix")
    if not isinstance(blocks, list) or not blocks:
        raise CampaignError(f"{where}: matrix: expected a non-empty list of blocks, got "
                            f"{blocks!r}")
    cells: list[Cell] = []
    for i, block in enumerate(blocks):
        cells += _block_cells(block, f"{where}: matrix[{i}]", scenarios=scenarios,
                              faulted=faulted, base=base, node_names=node_names)
    _check_unique(cells, where)
    return Campaign(name.strip(), tuple(cells), float(timeout))


def _check_unique(cells: Iterable[Cell], where: str) -> None:
    seen: dict[str, Cell] = {}
    for cell in cells:
        if cell.key in seen:
            raise CampaignError(f"{where}: the run {cell.key} is listed twice")
        seen[cell.key] = cell


def load_campaign(path: Path) -> Campaign:
    """The campaign of a YAML file, against the scenarios that exist."""
    from quadmission.evaluation.faults import NODE_STOP_EXPECTED
    from quadmission.scenarios import FAULTED_SCENARIOS, SCENARIOS

    try:
        data = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise CampaignError(f"{path}: {exc}") from None
    return parse_campaign(data, str(path), scenarios=SCENARIOS, faulted=FAULTED_SCENARIOS,
                          base=path.parent, default_name=path.stem,
                          node_names=frozenset(NODE_STOP_EXPECTED))
