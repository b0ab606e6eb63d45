"""Faults drawn from a run's seed (``draw_faults``): the same file gives the same runs,
every value inside its key's range, one or two faults apart in time and spread over the
window, errors that name the bad key, and the transient campaign that uses it (no
flights)."""

from __future__ import annotations

import itertools
import math
import random
import shlex
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from quadmission.campaigns.draw import DEFAULT_GAP_S, parse_draw, run_rng
from quadmission.campaigns.matrix import Campaign, load_campaign, parse_campaign
from quadmission.cli import build_parser
from quadmission.errors import CampaignError
from quadmission.evaluation.faults import NODE_STOP_EXPECTED, expectation
from quadmission.scenarios import FAULTED_SCENARIOS, SCENARIOS
from sim.arena import Lighting
from sim.fault_spec import KINDS, FaultKind, parse_fault, parse_faults

ROOT = Path(__file__).resolve().parents[3]
TRANSIENT = ROOT / "config" / "campaigns" / "transient.yaml"

DRAW = """
count: 1-2
window_s: [3, 450]
kinds:
  vio_stop: {duration_s: [1, 5]}
  link_lost: {duration_s: [0.5, 3]}
  packet_burst: {duration_s: [0.5, 3], loss: [0.3, 0.7]}
  camera_dark: {duration_s: [0.2, 1.5]}
  node_stop: {duration_s: [2, 6], name: [navigator, mapping], weight: 2}
"""
RANGES = {"vio_stop": (1, 5), "link_lost": (0.5, 3), "packet_burst": (0.5, 3),
          "camera_dark": (0.2, 1.5), "node_stop": (2, 6)}


def parse(text: str) -> Campaign:
    return parse_campaign(yaml.safe_load(text), "c.yaml", scenarios=SCENARIOS,
                          faulted=FAULTED_SCENARIOS, node_names=frozenset(NODE_STOP_EXPECTED))


def block(draw: str = DRAW, head: str = "scenarios: mission\n    seeds: 1-40") -> str:
    body = "\n".join("      " + line for line in draw.strip().splitlines())
    return f"matrix:\n  - {head}\n    draw_faults:\n{body}\n"


def test_the_same_file_gives_the_same_runs_and_other_blocks_other_runs() -> None:
    first, again = parse(block()), parse(block())
    assert [c.fault_specs for c in first.cells] == [c.fault_specs for c in again.cells]
    assert load_campaign(TRANSIENT).cells == load_campaign(TRANSIENT).cells
    # a seed's draw is its own: the runs of seeds 1-40 are those of seed 1-40 among more
    more = parse(block(head="scenarios: mission\n    seeds: 1-80"))
    assert more.cells[:40] == first.cells
    # another block (here: in the dark), or another lighting, draws other faults
    dark = parse(block(head="scenarios: mission\n    seeds: 1-40\n    lighting: dark"))
    assert sum(a.faults != b.faults for a, b in zip(first.cells, dark.cells,
                                                    strict=True)) >= 35
    both = parse(block(head="scenarios: mission\n    seeds: 1-40\n    lighting: [light, dark]"))
    pairs = zip(both.cells[::2], both.cells[1::2], strict=True)
    assert sum(a.faults != b.faults for a, b in pairs) >= 35
    assert run_rng(1, "a").random() == run_rng(1, "a").random() != run_rng(2, "a").random()


def test_drawn_faults_are_one_or_two_apart_in_the_window_each_value_in_its_range() -> None:
    draw = parse_draw(yaml.safe_load(DRAW), "d")
    counts, starts, kinds, names = set(), [], set(), set()
    for i in range(600):
        faults = draw.draw(random.Random(i))
        counts.add(len(faults))
        for f in faults:
            lo, hi = RANGES[f.kind.value]
            assert f.duration_s is not None and lo <= f.duration_s <= hi, f.spec()
            assert f.at_s >= 3 and f.end_s <= 450, f.spec()
            for key in KINDS[f.kind].keys:  # the spec table's own range, and the YAML's
                if not key.text:
                    assert key.lo <= f.value(key.name) <= key.hi, f.spec()
            if f.kind is FaultKind.PACKET_BURST:
                assert 0.3 <= f.value("loss") <= 0.7
            if f.kind is FaultKind.NODE_STOP:
                names.add(f.text("name"))
            assert parse_fault(f.spec()) == f, "the spec replays the very fault"
            starts.append(f.at_s)
            kinds.add(f.kind.value)
        for a, b in itertools.pairwise(faults):
            assert b.at_s >= a.end_s + DEFAULT_GAP_S - 1e-9, (a.spec(), b.spec())
    assert counts == {1, 2} and kinds == set(RANGES) and names == {"navigator", "mapping"}
    # spread over the window: every fifth of it holds a good share of the starts
    fifths = [sum(3 + k * 89.4 <= t < 3 + (k + 1) * 89.4 for t in starts) for k in range(5)]
    assert min(fifths) > 0.1 * len(starts), fifths


def test_a_fixed_count_and_value_and_a_kind_without_a_duration() -> None:
    draw = parse_draw({"count": 2, "window_s": [10, 100], "gap_s": 5, "kinds": {
        "wind_gust": {"duration_s": 2, "force": 3}, "vio_jump": {"x": [0.5, 0.5]}}}, "d")
    for i in range(50):
        faults = draw.draw(random.Random(i))
        assert len(faults) == 2
        for f in faults:
            if f.kind is FaultKind.WIND_GUST:
                assert (f.duration_s, f.value("force")) == (2.0, 3.0)
            else:
                assert f.duration_s is None and f.value("x") == 0.5 and 10 <= f.at_s <= 100


@pytest.mark.parametrize(("draw", "named"), [
    ({"count": 1, "window_s": [3, 9], "kinds": {"vio_stop": {}}, "gaps": 3},
     ["c.yaml: matrix[0].draw_faults", "unknown key 'gaps'", "gap_s"]),
    ({"window_s": [3, 9], "kinds": {"vio_stop": {}}}, ["draw_faults", "missing 'count'"]),
    ({"count": "0-2", "window_s": [3, 9], "kinds": {"vio_stop": {}}},
     ["draw_faults.count", "'0-2'"]),
    ({"count": 1, "window_s": [9, 3], "kinds": {"vio_stop": {}}},
     ["draw_faults.window_s", "ends before it starts"]),
    ({"count": 1, "window_s": [3, 9], "kinds": {"vio_stp": {}}},
     ["draw_faults.kinds.vio_stp", "unknown fault kind 'vio_stp'"]),
    ({"count": 1, "window_s": [3, 9], "kinds": {"vio_stop": {"duration": [1, 2]}}},
     ["draw_faults.kinds.vio_stop", "unknown key 'duration'", "duration_s"]),
    ({"count": 1, "window_s": [3, 90], "kinds": {"packet_burst": {"duration_s": [1, 2],
                                                                  "loss": [0.5, 1.5]}}},
     ["draw_faults.kinds.packet_burst.loss", "[0.5, 1.5]", "range [0, 1]"]),
    ({"count": 1, "window_s": [3, 90], "kinds": {"packet_burst": {"loss": 0.5}}},
     ["draw_faults.kinds.packet_burst", "needs duration_s"]),
    ({"count": 1, "window_s": [3, 90], "kinds": {"battery_low": {"duration_s": 2}}},
     ["draw_faults.kinds.battery_low.duration_s", "takes no duration"]),
    ({"count": 1, "window_s": [3, 90], "kinds": {"vio_stop": {"duration_s": [0.01, 0.05]}}},
     ["draw_faults.kinds.vio_stop.duration_s", "no multiple of 0.1 s"]),
    ({"count": 1, "window_s": [3, 90], "kinds": {"node_stop": {"duration_s": 2}}},
     ["draw_faults.kinds.node_stop", "needs name"]),
    ({"count": 1, "window_s": [3, 90], "kinds": {"node_stop": {"duration_s": 2,
                                                               "name": ["navigatr"]}}},
     ["draw_faults.kinds.node_stop.name", "'navigatr'", "navigator"]),
    ({"count": 1, "window_s": [3, 90], "kinds": {"vio_stop": {"weight": 0}}},
     ["draw_faults.kinds.vio_stop.weight", "0"]),
    ({"count": 2, "window_s": [3, 40], "kinds": {"vio_stop": {"duration_s": [1, 5]}}},
     ["draw_faults.window_s", "[3, 40]", "shorter than 2 of the longest faults (5 s)", "(40 s)"]),
])
def test_a_bad_draw_is_refused_naming_the_key_and_the_value(draw: dict[str, object],
                                                            named: list[str]) -> None:
    with pytest.raises(CampaignError) as caught:
        parse(block(yaml.safe_dump(draw)))
    for part in named:
        assert part in str(caught.value), (part, str(caught.value))


def test_a_block_draws_or_lists_its_faults_and_its_scenario_must_take_the_kinds() -> None:
    with pytest.raises(CampaignError, match=r"matrix\[0\]: faults and draw_faults together"):
        parse(block(head="scenarios: mission\n    seeds: 1\n    faults: [vio_stop@5]"))
    with pytest.raises(CampaignError, match=r"draw_faults.kinds: scenario 'navigate' cannot "
                                            r"take camera_dark"):
        parse(block("count: 1\nwindow_s: [3, 90]\nkinds: {camera_dark: {duration_s: 1}}",
                    head="scenarios: navigate\n    seeds: 1"))


def test_the_transient_campaign_is_60_unseen_arenas_light_and_dark_each_with_drawn_faults(
) -> None:
    cells = load_campaign(TRANSIENT).cells
    assert len(cells) >= 60
    arenas = load_campaign(TRANSIENT.parent / "arenas.yaml").cells
    assert not {c.seed for c in cells} & {c.seed for c in arenas}, "arenas tuned on"
    for light in Lighting:
        assert {c.seed for c in cells if c.lighting is light} == set(range(200, 230))
    kinds, names = set(), set()
    for cell in cells:
        assert cell.scenario == "mission" and cell.arena is None and 1 <= len(cell.faults) <= 2
        assert parse_faults(cell.fault_specs) == cell.faults
        for f in cell.faults:
            # transient: over within the mission, a reaction that lets it complete
            assert f.duration_s is not None and f.end_s <= 600
            judged = expectation(f)
            assert judged.recovers or judged.completes, f.spec()
            kinds.add(f.kind)
            if f.kind is FaultKind.NODE_STOP:
                names.add(f.text("name"))
    assert kinds == {FaultKind.VIO_STOP, FaultKind.LINK_LOST, FaultKind.PACKET_BURST,
                     FaultKind.CAMERA_DARK, FaultKind.NODE_STOP}
    listed = yaml.safe_load(TRANSIENT.read_text())["matrix"][0]["draw_faults"]["kinds"]
    assert names == set(listed["node_stop"]["name"]), "every node listed is stopped once"
    assert not names & {"mission", "operator", "vio", "fcu_bridge"}
    # the whole mission: some faults before the take-off's end, many in the landings
    starts = sorted(f.at_s for c in cells for f in c.faults)
    assert starts[0] < 30 and starts[-1] > 550 and sum(t > 300 for t in starts) > 20


def test_a_drawn_run_replays_with_its_specs_on_the_command_line(tmp_path: Path) -> None:
    cell = next(c for c in load_campaign(TRANSIENT).cells if len(c.faults) == 2)
    line = cell.replay_command(tmp_path / cell.key)
    for spec in cell.fault_specs:
        assert f"--fault {shlex.quote(spec)}" in line
    args = build_parser().parse_args(shlex.split(line)[1:])
    assert (args.seed, args.random_arena, args.lighting) == (cell.seed, True,
                                                             cell.lighting_name)
    assert parse_faults(args.fault) == cell.faults


def test_the_draw_module_is_pure() -> None:
    script = ("import sys\nimport quadmission.campaigns.draw\n"
              "print(sorted({m.split('.')[0] for m in sys.modules} & {'dask', 'distributed',"
              " 'mujoco', 'fsm'}))")
    done = subprocess.run([sys.executable, "-c", script], cwd=ROOT, capture_output=True,
                          text=True, timeout=120, check=True)
    assert done.stdout.strip() == "[]"
    assert math.isfinite(DEFAULT_GAP_S)
