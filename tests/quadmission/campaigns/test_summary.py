"""A campaign's figures from its rows and summary.md: rates per fault kind and lighting,
percentiles, re-queued runs, and every failed run with the line that replays it."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from quadmission.campaigns.plots import PICTURES, save_plots
from quadmission.campaigns.summary import (
    CLEAN,
    UNKNOWN_VERSION,
    Percentiles,
    Session,
    render_markdown,
    summarize,
    summary_json,
)

SESSION = Session("t", "t.yaml", cells=5, skipped=1, ran=3, lost=1, where="a test",
                  wall_s=12.0)


def make_row(cell: str, kinds: list[str], passed: bool, lighting: str = "light",
             reactions: list[float | None] | None = None, errors: list[float] | None = None,
             attempts: int = 1, wall_s: float = 10.0) -> dict[str, Any]:
    reactions = reactions if reactions is not None else [0.5] * len(kinds)
    return {"cell": cell, "scenario": "mission", "lighting": lighting,
            "faults": [f"{k}@40" for k in kinds], "fault_kinds": kinds,
            "expected": [f"{k}: HOLD" for k in kinds],
            "observed": [f"{k}: HOLD" if passed else "none" for k in kinds],
            "fault_handled": [passed] * len(kinds), "reaction_s": reactions,
            "handled": passed, "passed": passed, "crashed": False, "end_state": "holding",
            "result": "stopped", "reason": None, "verdict": "v",
            "landings": len(errors or []), "landings_inside": len(errors or []),
            "touchdown_errors_m": errors or [], "attempts": attempts,
            "wall_s": wall_s, "cpu_s": wall_s / 2, "replay": f"quadmission sim --out {cell}",
            "code_version": "0123456789ab"}


ROWS = [
    make_row("a", ["vio_stop"], True, reactions=[0.7]),
    make_row("b", ["vio_stop", "battery_low"], False, lighting="dark", reactions=[None, 2.0]),
    make_row("c", [], True, errors=[0.01, 0.03], attempts=2),
    make_row("d", [], False, lighting="dark", errors=[0.02], wall_s=40.0),
]


def test_rates_count_each_run_once_per_kind_and_clean_runs_apart() -> None:
    s = summarize(ROWS)
    assert (s.runs, s.passed, s.requeued) == (4, 2, 1)
    kinds = {k.rate.group: k for k in s.by_kind}
    assert {g: (k.rate.passed, k.rate.runs) for g, k in kinds.items()} == {
        "vio_stop": (1, 2), "battery_low": (0, 1), CLEAN: (1, 2)}
    assert kinds["vio_stop"].reaction_s.n == 1  # no reaction seen: not a time
    assert kinds["vio_stop"].observed == (("vio_stop: HOLD", 1), ("none", 1))
    assert {r.group: (r.passed, r.runs) for r in s.by_lighting} == {"light": (2, 2),
                                                                    "dark": (0, 2)}
    assert (s.landings, s.touchdown_m.n, s.touchdown_m.max) == (3, 3, 0.03)
    assert s.wall_total_s == 70.0 and s.runs_per_cpu_hour == pytest.approx(4 * 3600 / 35)
    assert [f.cell for f in s.failed] == ["b", "d"]


def test_percentiles() -> None:
    p = Percentiles.of([4.0, None, 1.0, 2.0, 3.0])
    assert (p.n, p.p50, p.max) == (4, 2.5, 4.0)
    assert p.p90 == pytest.approx(3.7)
    assert Percentiles.of([None]) == Percentiles(0)


def test_the_summary_lists_each_failed_run_with_its_replay_line() -> None:
    text = render_markdown(summarize(ROWS), SESSION, PICTURES)
    assert "**Passed: 50 % (2/4).**" in text
    assert "| vio_stop | 50 % (1/2) |" in text and "| dark | 0 % (0/2) |" in text
    assert "Re-queued after a lost worker: 1 run(s)" in text
    assert "**1 not finished**" in text
    failed = text.split("## Failed runs")[1]
    for row in ROWS:
        assert (f"  {row['replay']}\n" in failed) is (not row["passed"]), row["cell"]
    assert "vio_stop@40: expected vio_stop: HOLD, observed none" in failed
    for _, name in PICTURES:
        assert f"]({name})" in text


def test_the_plots_are_written(tmp_path: Path) -> None:
    save_plots(summarize(ROWS), ROWS, tmp_path)
    for _, name in PICTURES:
        assert (tmp_path / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    save_plots(summarize([]), [], tmp_path)  # nothing finished yet: empty plots, no error


def test_one_code_version_is_named_and_several_are_flagged_with_their_runs() -> None:
    text = render_markdown(summarize(ROWS), SESSION)
    assert "Code: `0123456789ab` (4 runs)." in text
    assert "(code `0123456789ab`)" in text.split("## Failed runs")[1]
    mixed = [*ROWS[:3], {**ROWS[3], "code_version": None}]  # a row from an older report
    s = summarize(mixed)
    assert s.code_versions == (("0123456789ab", 3), (UNKNOWN_VERSION, 1))
    text = render_markdown(s, SESSION)
    assert "**Rows flown by 2 code versions**: `0123456789ab` (3 runs), `unknown` (1 run)" \
        in text
    assert f"- `d` (code `{UNKNOWN_VERSION}`)" in text


def test_summary_json_carries_the_rates_and_figures_of_the_markdown() -> None:
    body = json.loads(summary_json(summarize(ROWS), SESSION))
    assert body["session"]["name"] == "t" and body["session"]["lost"] == 1
    s = body["summary"]
    assert s["rate"] == {"group": "all", "runs": 4, "passed": 2, "rate": 0.5}
    kinds = {k["rate"]["group"]: k for k in s["by_kind"]}
    assert kinds["vio_stop"]["rate"]["rate"] == 0.5 and kinds["vio_stop"]["reaction_s"]["n"] == 1
    assert {r["group"]: r["rate"] for r in s["by_lighting"]} == {"light": 1.0, "dark": 0.0}
    assert s["touchdown_m"]["max"] == 0.03 and s["runs_per_cpu_hour"] == pytest.approx(
        4 * 3600 / 35)
    assert [f["cell"] for f in s["failed"]] == ["b", "d"]
    assert s["code_versions"] == [["0123456789ab", 4]]
