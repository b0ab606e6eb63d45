"""One row per run: what a cell's ``report.json`` and its process say, as a flat record;
the rows kept one JSON file a cell (so a campaign resumes) and gathered into Parquet.
Pure: pyarrow, no Dask.

A row's verdicts (see :func:`row_of`):

- ``result``: the scenario's own (mission: ``completed`` | ``stopped``; square:
  ``landed`` | ``crash`` | ``failed`` | ``refused``), or ``error`` (the run raised, or
  died: no report) or ``timeout`` (stopped after the campaign's ``timeout_s``);
- ``ok``: the scenario's own check (``quadmission sim`` exit code 0);
- ``handled`` (issue 22): the run flew (no error, no time-out, not refused), did not
  crash, and every fault's observed reaction was the expected one (vacuous when clean);
- ``passed``: what the campaign counts: ``handled`` for a faulted run, ``ok`` for a clean
  one (a clean mission must complete with every landing inside its pad).
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.parquet as pq

from quadmission.campaigns.matrix import Cell
from quadmission.reports.report import VERSION_KEY

__all__ = ["CELLS_DIR", "RESULTS_NAME", "RUNS_DIR", "SCHEMA", "CellStore", "RunOutcome",
           "row_of", "write_parquet"]

RESULTS_NAME = "results.parquet"
RUNS_DIR = "runs"  # DIR/runs/<cell key>/: each run's report.json, pictures, log
CELLS_DIR = "cells"  # DIR/cells/<cell key>.json: each finished run's row

SCHEMA = pa.schema([
    ("cell", pa.string()),
    ("scenario", pa.string()),
    ("seed", pa.int64()),
    ("arena", pa.string()),  # "random" or the arena file
    ("arena_name", pa.string()),  # the arena flown (random-<seed>, contest...)
    ("lighting", pa.string()),  # light | dark | arena (the arena's own)
    ("faults", pa.list_(pa.string())),  # the specs, as given to --fault
    ("fault_kinds", pa.list_(pa.string())),
    ("handled", pa.bool_()),
    ("passed", pa.bool_()),
    ("ok", pa.bool_()),
    ("result", pa.string()),
    ("reason", pa.string()),
    ("verdict", pa.string()),
    ("crashed", pa.bool_()),
    ("expected", pa.list_(pa.string())),  # per fault
    ("observed", pa.list_(pa.string())),  # per fault
    ("fault_handled", pa.list_(pa.bool_())),  # per fault
    ("reaction_s", pa.list_(pa.float64())),  # per fault; null: no reaction seen
    ("end_state", pa.string()),
    ("landings", pa.int64()),
    ("landings_inside", pa.int64()),
    ("touchdown_errors_m", pa.list_(pa.float64())),
    ("touchdown_max_m", pa.float64()),
    ("score", pa.int64()),
    ("max_score", pa.int64()),
    ("sim_s", pa.float64()),
    ("wall_s", pa.float64()),  # the run's process, start to end
    ("cpu_s", pa.float64()),  # the run's process: user + system
    ("exit_code", pa.int64()),
    ("attempts", pa.int64()),  # 2 and more: its worker was lost and the run re-queued
    ("worker", pa.string()),
    ("run_dir", pa.string()),
    ("replay", pa.string()),  # the one-line command that flies it again
    ("code_version", pa.string()),  # the code that flew it (report.json's; null: none)
])


@dataclass(frozen=True)
class RunOutcome:
    """How a cell's process ended: its exit code (None: stopped at the time limit), wall
    and CPU seconds, the report it wrote (None: none) and the tail of its log."""

    exit_code: int | None
    wall_s: float
    cpu_s: float
    report: dict[str, Any] | None
    log_tail: str = ""


def _result(outcome: RunOutcome) -> tuple[str, str | None]:
    """The run's result and, when it went wrong, why."""
    report = outcome.report
    if outcome.exit_code is None:
        return "timeout", f"stopped after {outcome.wall_s:.0f} s of wall time"
    if report is None or outcome.exit_code not in (0, 1, 2):
        code = outcome.exit_code
        why = f"killed by signal {-code}" if code < 0 else f"exit code {code}"
        last = next((line for line in reversed(outcome.log_tail.splitlines()) if line.strip()),
                    "no output")  # a traceback's last line: the exception
        return "error", f"{why}: {last.strip()[:300]}"
    result = report.get("result", report.get("outcome"))
    return str(result), report.get("reason") or report.get("refused")


def row_of(cell: Cell, outcome: RunOutcome, *, run_dir: Path, worker: str,
           attempts: int = 1) -> dict[str, Any]:
    """The row of one run (columns: :data:`SCHEMA`)."""
    report = outcome.report or {}
    result, reason = _result(outcome)
    faults = report.get("faults") or []
    crashed = bool(report.get("crashed", report.get("crash") is not None))
    landings = report.get("landings") or []
    errors = [d["touchdown_error_m"] for d in landings
              if d.get("touchdown_error_m") is not None]
    ok = outcome.exit_code == 0
    sane = result not in ("error", "timeout", "refused") and bool(report)  # it flew
    handled = sane and not crashed and all(f["handled"] for f in faults)
    if cell.faults and len(faults) != len(cell.faults):
        handled = False  # a faulted run must judge each of its faults
    lighting = (cell.lighting.value if cell.lighting is not None
                else str(report.get("lighting", "arena")))
    return {
        "cell": cell.key, "scenario": cell.scenario, "seed": cell.seed,
        "arena": "random" if cell.arena is None else str(cell.arena),
        "arena_name": report.get("arena"), "lighting": lighting,
        "faults": list(cell.fault_specs), "fault_kinds": [f.kind.value for f in cell.faults],
        "handled": handled, "passed": handled if cell.faults else ok and sane,
        "ok": ok, "result": result, "reason": reason, "verdict": report.get("verdict"),
        "crashed": crashed,
        "expected": [f["expected"] for f in faults],
        "observed": [f["observed"] for f in faults],
        "fault_handled": [bool(f["handled"]) for f in faults],
        "reaction_s": [f["reaction_s"] for f in faults],
        "end_state": faults[0]["end_state"] if faults else None,
        "landings": len(landings) if "landings" in report else None,
        "landings_inside": (sum(bool(d.get("inside_pad")) for d in landings)
                            if "landings" in report else None),
        "touchdown_errors_m": errors,
        "touchdown_max_m": max(errors) if errors else None,
        "score": report.get("score"), "max_score": report.get("max_score"),
        "sim_s": report.get("sim_time_s"),
        "wall_s": round(outcome.wall_s, 3), "cpu_s": round(outcome.cpu_s, 3),
        "exit_code": outcome.exit_code, "attempts": attempts, "worker": worker,
        "run_dir": str(run_dir), "replay": cell.replay_command(run_dir),
        "code_version": report.get(VERSION_KEY),
    }


class CellStore:
    """Finished runs' rows, one JSON file a cell under ``DIR/cells/``: written as each run
    ends (atomically), read back to resume and to build the Parquet table."""

    def __init__(self, out: Path) -> None:
        self.folder = out / CELLS_DIR

    def path(self, key: str) -> Path:
        return self.folder / f"{key}.json"

    def done(self, cells: Iterable[Cell]) -> set[str]:
        """The keys of ``cells`` that have a row."""
        return {c.key for c in cells if self.path(c.key).is_file()}

    def put(self, row: dict[str, Any]) -> None:
        self.folder.mkdir(parents=True, exist_ok=True)
        final = self.path(row["cell"])
        part = final.with_suffix(".json.part")
        part.write_text(json.dumps(row, indent=1, allow_nan=False) + "\n")
        os.replace(part, final)  # a campaign killed mid-write leaves no half row

    def rows(self, cells: Sequence[Cell]) -> list[dict[str, Any]]:
        """The rows of ``cells`` that finished, in the campaign's order."""
        return [json.loads(self.path(c.key).read_text()) for c in cells
                if self.path(c.key).is_file()]


def write_parquet(rows: Sequence[dict[str, Any]], path: Path) -> Path:
    """``rows`` as a Parquet table with :data:`SCHEMA` (the columns even with no row)."""
    table = pa.Table.from_pylist([{k: r.get(k) for k in SCHEMA.names} for r in rows],
                                 schema=SCHEMA)
    part = path.with_suffix(".parquet.part")
    pq.write_table(table, part)
    os.replace(part, path)
    return path
