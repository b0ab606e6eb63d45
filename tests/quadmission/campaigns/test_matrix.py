"""The campaign file: validation that names the bad key and value, the matrix's expansion,
the cells' keys, and the replay line, read back by the real CLI parser."""

from __future__ import annotations

import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from quadmission.campaigns.matrix import (
    MAX_KEY_CHARS,
    Campaign,
    Cell,
    load_campaign,
    parse_campaign,
)
from quadmission.cli import build_parser
from quadmission.errors import CampaignError
from quadmission.scenarios import FAULTED_SCENARIOS, SCENARIOS
from sim.arena import Lighting
from sim.fault_spec import FaultKind, parse_fault, parse_faults

ROOT = Path(__file__).resolve().parents[3]
CAMPAIGNS = ROOT / "config" / "campaigns"


def parse(text: str, base: Path = ROOT) -> Campaign:
    return parse_campaign(yaml.safe_load(text), "c.yaml", scenarios=SCENARIOS,
                          faulted=FAULTED_SCENARIOS, base=base)


def test_the_faults_campaign_flies_every_fault_kind_on_three_seeds() -> None:
    campaign = load_campaign(CAMPAIGNS / "faults.yaml")
    kinds: dict[FaultKind, set[int]] = {}
    for cell in campaign.cells:
        assert cell.scenario in FAULTED_SCENARIOS and len(cell.faults) == 1
        kinds.setdefault(cell.faults[0].kind, set()).add(cell.seed)
    assert set(kinds) == set(FaultKind), "a fault kind is missing from faults.yaml"
    assert all(len(seeds) == 3 for seeds in kinds.values()), kinds
    # vio_stop and link_lost twice: for a while (the mission's recovery) and for good
    twice = {FaultKind.VIO_STOP, FaultKind.LINK_LOST}
    assert len(campaign.cells) == 3 * (len(FaultKind) + len(twice))
    for kind in twice:
        ends = {c.faults[0].duration_s is None for c in campaign.cells
                if c.faults[0].kind is kind}
        assert ends == {True, False}, kind


def test_the_arenas_campaign_is_75_clean_missions_on_random_arenas() -> None:
    cells = load_campaign(CAMPAIGNS / "arenas.yaml").cells
    assert all(c.scenario == "mission" and c.arena is None and not c.faults for c in cells)
    light = sorted(c.seed for c in cells if c.lighting is Lighting.LIGHT)
    dark = sorted(c.seed for c in cells if c.lighting is Lighting.DARK)
    assert light == list(range(100, 150)) and dark == list(range(100, 125))
    assert len(cells) == 75


def test_the_matrix_expands_with_the_fault_sets_varying_fastest() -> None:
    campaign = parse("""
matrix:
  - scenarios: [square, mission]
    seeds: 3-4
    lighting: [light, dark]
    faults: [[], vio_stop@5, [link_lost@3:1, wind_gust@4:1]]
""")
    cells = campaign.cells
    assert len(cells) == 2 * 2 * 2 * 3
    assert [c.fault_specs for c in cells[:3]] == [(), ("vio_stop@5",),
                                                  ("link_lost@3:1", "wind_gust@4:1,force=2,"
                                                   "direction_deg=0")]
    assert (cells[0].scenario, cells[0].seed, cells[0].lighting) == ("square", 3,
                                                                       Lighting.LIGHT)
    assert (cells[3].seed, cells[3].lighting) == (3, Lighting.DARK)
    assert cells[-1].scenario == "mission" and cells[-1].seed == 4
    assert campaign.limited(5).cells == cells[:5]
    assert campaign.name == "campaign" and campaign.timeout_s == 3600.0


@pytest.mark.parametrize(("text", "named"), [
    ("matrix: [{scenarios: square, seeds: [1]}]\nnmae: x", ["c.yaml", "'nmae'"]),
    ("matrix: [{scenarios: square, seed: [1]}]", ["matrix[0]", "'seed'", "allowed"]),
    ("matrix: [{scenarios: [square, sqaure], seeds: [1]}]",
     ["matrix[0].scenarios", "'sqaure'", "known"]),
    ("matrix: [{scenarios: square, seeds: [1], faults: [vio_stop@5, vio_stp@5]}]",
     ["matrix[0].faults[1]", "'vio_stp'"]),
    ("matrix: [{scenarios: square, seeds: [1], faults: [['wind_gust@5:1,force=99']]}]",
     ["matrix[0].faults[0][0]", "force=99", "[0, 50] N"]),
    ("matrix: [{scenarios: square, seeds: [1], faults: [[wind_gust@5:1,force=3]]}]",
     ["matrix[0].faults[0][1]", "'force=3'", "quote the spec"]),
    ("matrix: [{scenarios: [square, arena-tour], seeds: [1], faults: [vio_stop@5]}]",
     ["matrix[0].faults", "'arena-tour' takes no faults"]),
    ("matrix: [{scenarios: [square, navigate], seeds: [1], faults: [vio_stop@5]}]",
     ["matrix[0].faults", "'navigate' cannot take vio_stop", "link_lost"]),
    ("matrix: [{scenarios: square, seeds: [1], lighting: dim}]",
     ["matrix[0].lighting", "'dim'", "light, dark"]),
    ("matrix: [{scenarios: square, seeds: 100-}]", ["matrix[0].seeds", "'100-'"]),
    ("matrix: [{scenarios: square, seeds: [1, -2]}]", ["matrix[0].seeds", "-2"]),
    ("matrix: [{scenarios: square, seeds: [1], arena: nowhere.yaml}]",
     ["matrix[0].arena", "nowhere.yaml"]),
    ("matrix: [{scenarios: square}]", ["matrix[0]", "missing 'seeds'"]),
    ("name: x", ["matrix", "non-empty list"]),
    ("timeout_s: 0\nmatrix: [{scenarios: square, seeds: [1]}]", ["timeout_s", "0"]),
    ("matrix: [{scenarios: square, seeds: [1]}, {scenarios: square, seeds: [0-1]}]",
     ["square_random1_arena_clean", "twice"]),
])
def test_a_bad_campaign_is_refused_naming_the_key_and_the_value(text: str,
                                                               named: list[str]) -> None:
    with pytest.raises(CampaignError) as caught:
        parse(text.replace("[0-1]", "0-1"))
    for part in named:
        assert part in str(caught.value), (part, str(caught.value))


def test_a_yaml_error_names_the_file(tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("matrix: [{scenarios: square\n")
    with pytest.raises(CampaignError, match=r"bad\.yaml"):
        load_campaign(bad)
    with pytest.raises(CampaignError, match="--limit 0"):
        parse("matrix: [{scenarios: square, seeds: [1]}]").limited(0)


def test_an_arena_path_is_found_beside_the_campaign_file(tmp_path: Path) -> None:
    (tmp_path / "campaigns").mkdir()
    arena = tmp_path / "my_arena.yaml"
    arena.write_text("unused: here\n")
    campaign = parse("matrix: [{scenarios: square, seeds: [1], arena: ../my_arena.yaml}]",
                     base=tmp_path / "campaigns")
    assert campaign.cells[0].arena == arena.resolve()
    assert campaign.cells[0].key == "square_my_arena-s1_arena_clean"


def test_keys_are_unique_folder_names_and_stable() -> None:
    cells = [*load_campaign(CAMPAIGNS / "faults.yaml").cells,
             *load_campaign(CAMPAIGNS / "arenas.yaml").cells]
    keys = [c.key for c in cells]
    assert len(set(keys)) == len(keys)
    assert all(re.fullmatch(r"[A-Za-z0-9_.,:=@+-]{1,100}", k) for k in keys)
    many = tuple(parse_fault(f"wind_gust@{t}:1,force=3") for t in range(30))
    long_one = Cell("square", 1, faults=many)
    other = Cell("square", 1, faults=many[:-1])
    assert len(long_one.key) == MAX_KEY_CHARS and long_one.key != other.key
    assert long_one.key == Cell("square", 1, faults=many).key


@pytest.mark.parametrize("cell", [
    Cell("square", 7, None, Lighting.DARK, parse_faults(["vio_stop@12:2", "link_lost@3"])),
    Cell("mission", 0, ROOT / "config/arenas/contest.yaml", None,
         parse_faults(["wind_gust@150:2,force=3"])),
    Cell("mission", 101),
])
def test_the_replay_line_is_a_quadmission_sim_command_for_the_same_run(cell: Cell) -> None:
    out = Path("/tmp/some dir/runs") / cell.key
    words = shlex.split(cell.replay_command(out))
    assert words[0] == "quadmission"
    args = build_parser().parse_args(words[1:])
    assert (args.command, args.scenario, args.seed, args.out) == ("sim", cell.scenario,
                                                                  cell.seed, out)
    assert args.random_arena == (cell.arena is None) and args.arena == cell.arena
    assert args.lighting == (cell.lighting.value if cell.lighting else None)
    assert parse_faults(args.fault) == cell.faults


def test_the_pure_modules_import_no_dask() -> None:
    script = ("import sys\nimport quadmission.campaigns.matrix, quadmission.campaigns.results,"
              " quadmission.campaigns.summary\n"
              "print(sorted(m for m in sys.modules if m.split('.')[0] in "
              "('dask', 'distributed', 'tqdm')))")
    done = subprocess.run([sys.executable, "-c", script], cwd=ROOT, capture_output=True,
                          text=True, timeout=120, check=True)
    assert done.stdout.strip() == "[]"
