"""A run's row from its report and its process, the store that makes a campaign resume,
the Parquet table, and a cell's process (exit codes, the time limit)."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import pyarrow.parquet as pq
import pytest

from quadmission.campaigns.matrix import Cell
from quadmission.campaigns.process import run_sim
from quadmission.campaigns.results import SCHEMA, CellStore, RunOutcome, row_of, write_parquet
from sim.fault_spec import parse_faults

FAULTED = Cell("square", 7, faults=parse_faults(["link_lost@12:3", "wind_gust@20:1"]))
CLEAN = Cell("mission", 101)


def fault(kind: str, handled: bool, observed: str = "FAILSAFE",
          reaction_s: float | None = 1.0) -> dict[str, Any]:
    return {"kind": kind, "expected": "FAILSAFE", "observed": observed,
            "reaction_s": reaction_s, "end_state": "holding", "handled": handled}


def row(cell: Cell, exit_code: int | None, report: dict[str, Any] | None,
        log: str = "") -> dict[str, Any]:
    return row_of(cell, RunOutcome(exit_code, 12.5, 10.0, report, log),
                  run_dir=Path("/c/runs") / cell.key, worker="tcp://w:1")


def test_a_faulted_run_is_handled_only_when_every_fault_is() -> None:
    report = {"outcome": "failed", "verdict": "FAILED: lost offboard", "crash": None,
              "sim_time_s": 33.0, "arena": "random-7",
              "faults": [fault("link_lost", True), fault("wind_gust", True, "none", None)]}
    good = row(FAULTED, 1, report)
    assert (good["handled"], good["passed"], good["ok"]) == (True, True, False)
    assert good["result"] == "failed" and good["fault_kinds"] == ["link_lost", "wind_gust"]
    assert good["reaction_s"] == [1.0, None] and good["end_state"] == "holding"
    assert good["code_version"] is None  # the report did not say
    assert row(FAULTED, 1, report | {"code_version": "0123456789ab"})["code_version"] == \
        "0123456789ab"
    report["faults"][1] = fault("wind_gust", False, "none", None)
    assert not row(FAULTED, 1, report)["passed"]
    crashed = report | {"faults": [fault("link_lost", True)] * 2,
                        "crash": {"reason": "hit wall_west"}, "outcome": "crash"}
    assert not row(FAULTED, 1, crashed)["handled"]
    missing = report | {"faults": [fault("link_lost", True)]}  # one fault not judged
    assert not row(FAULTED, 1, missing)["handled"]


def test_a_clean_run_passes_by_the_scenarios_own_check() -> None:
    from quadmission.evaluation.mission import Landing

    # the landings as the mission's report writes them (a key of our own would pass here
    # and read 0 inside from every real report)
    landings = [Landing(2, 100.0, (1.0, 1.0), 0.02, True).to_json(),
                Landing(3, 200.0, (5.0, 5.0), 0.61, False).to_json()]
    report = {"result": "completed", "crashed": False, "landings": landings, "score": 300,
              "max_score": 310, "lighting": "dark", "verdict": "completed"}
    failed = row(CLEAN, 1, report)  # a landing outside: the mission's check fails
    assert (failed["handled"], failed["passed"]) == (True, False)
    assert (failed["landings"], failed["landings_inside"]) == (2, 1)
    assert failed["touchdown_errors_m"] == [0.02, 0.61] and failed["touchdown_max_m"] == 0.61
    assert failed["lighting"] == "dark"  # the arena's own, read from the report
    assert row(CLEAN, 0, report)["passed"]


@pytest.mark.parametrize(("exit_code", "report", "result", "why"), [
    (None, None, "timeout", "stopped after 12 s"),
    (-11, None, "error", "killed by signal 11: Traceback: Segmentation fault"),
    (1, None, "error", "exit code 1: Traceback"),
    (0, None, "error", "exit code 0"),
    (2, {"outcome": "refused", "refused": "no square fits"}, "refused", "no square fits"),
])
def test_a_run_that_did_not_finish_is_an_error_never_a_pass(
        exit_code: int | None, report: dict[str, Any] | None, result: str, why: str) -> None:
    r = row(CLEAN, exit_code, report, log="...\nTraceback: Segmentation fault\n")
    assert r["result"] == result and why in r["reason"]
    assert not r["passed"] and not r["handled"]
    assert not row(FAULTED, exit_code, report)["passed"]


def test_the_store_resumes_from_the_rows_it_kept(tmp_path: Path) -> None:
    store = CellStore(tmp_path)
    cells = [Cell("square", seed) for seed in (1, 2, 3)]
    assert store.done(cells) == set()
    store.put(row(cells[2], 0, {"outcome": "landed"}))
    store.put(row(cells[0], 0, {"outcome": "landed"}))
    store.path(cells[1].key).with_suffix(".json.part").write_text("{half")  # killed mid-write
    assert store.done(cells) == {cells[0].key, cells[2].key}
    assert [r["cell"] for r in store.rows(cells)] == [cells[0].key, cells[2].key]  # in order
    assert store.rows(cells[1:2]) == []


def test_the_parquet_table_has_every_column_even_empty(tmp_path: Path) -> None:
    assert pq.read_table(write_parquet([], tmp_path / "r.parquet")).schema == SCHEMA
    rows = [row(FAULTED, 1, {"outcome": "failed", "faults": [fault("link_lost", True)] * 2}),
            row(CLEAN, None, None)]
    table = pq.read_table(write_parquet(rows, tmp_path / "r.parquet"))
    assert table.to_pylist() == rows
    assert not list(tmp_path.glob("*.part"))


def test_a_run_past_the_time_limit_is_stopped(tmp_path: Path) -> None:
    started = time.monotonic()
    outcome = run_sim(["sim", "--scenario", "square", "--out", str(tmp_path)], tmp_path,
                      timeout_s=1.5)
    assert outcome.exit_code is None and time.monotonic() - started < 30
    assert row_of(CLEAN, outcome, run_dir=tmp_path, worker="w")["result"] == "timeout"
