"""A campaign's figures from its rows, and ``summary.md`` (pure: numpy, no Dask).

:func:`summarize` gives the pass rate per fault kind (a clean run counts under
``clean``; a run with two faults under both kinds), per lighting and per scenario, the
touchdown-error and reaction-time percentiles, wall and CPU time, how many runs were
re-queued after a lost worker, the code versions that flew the rows, and every failed run
with its replay line; :func:`render_markdown` writes them for a person, :func:`summary_json`
for a program.
"""

from __future__ import annotations

import dataclasses
import json
from collections import Counter
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["CLEAN", "UNKNOWN_VERSION", "CampaignSummary", "FailedRun", "KindStats",
           "Percentiles", "Rate", "Session", "render_markdown", "summarize", "summary_json"]

CLEAN = "clean"  # the "fault kind" of a run without faults
UNKNOWN_VERSION = "unknown"  # a row whose report did not say which code flew it
PERCENTILES = (50, 90, 99)
S_PER_HOUR = 3600.0


@dataclass(frozen=True)
class Percentiles:
    """p50, p90, p99 and max of ``n`` values (None each when there are none)."""

    n: int
    p50: float | None = None
    p90: float | None = None
    p99: float | None = None
    max: float | None = None

    @classmethod
    def of(cls, values: Iterable[float | None]) -> Percentiles:
        data = np.array([v for v in values if v is not None], dtype=np.float64)
        if not data.size:
            return cls(0)
        p50, p90, p99 = (float(np.percentile(data, q)) for q in PERCENTILES)
        return cls(int(data.size), p50, p90, p99, float(data.max()))


@dataclass(frozen=True)
class Rate:
    """How many of a group's runs passed."""

    group: str
    runs: int
    passed: int

    @property
    def rate(self) -> float:
        return self.passed / self.runs if self.runs else 0.0


@dataclass(frozen=True)
class KindStats:
    """One fault kind over the campaign: its pass rate, the reaction expected, the
    reactions observed (most frequent first) and the reaction times [s]."""

    rate: Rate
    expected: str
    observed: tuple[tuple[str, int], ...]
    reaction_s: Percentiles


@dataclass(frozen=True)
class FailedRun:
    cell: str
    result: str
    why: str
    replay: str
    code_version: str  # the code that flew it: the replay's


@dataclass(frozen=True)
class CampaignSummary:
    runs: int
    passed: int
    requeued: int  # runs whose worker was lost at least once (re-queued, run again)
    by_kind: tuple[KindStats, ...]
    by_lighting: tuple[Rate, ...]
    by_scenario: tuple[Rate, ...]
    landings: int
    landings_inside: int
    touchdown_m: Percentiles
    wall_s: Percentiles  # per run
    wall_total_s: float  # the runs' wall time added up
    cpu_total_s: float
    failed: tuple[FailedRun, ...]
    code_versions: tuple[tuple[str, int], ...]  # (code version, runs), most runs first

    @property
    def runs_per_cpu_hour(self) -> float | None:
        return self.runs * S_PER_HOUR / self.cpu_total_s if self.cpu_total_s > 0 else None


@dataclass(frozen=True)
class Session:
    """What one ``quadmission campaign`` invocation did, for the summary's head."""

    name: str
    source: str  # the campaign file
    cells: int  # in the campaign (after --limit)
    skipped: int  # finished before this invocation (resumed)
    ran: int  # finished in this invocation
    lost: int  # not finished: their worker lost too often, or the campaign interrupted
    where: str  # the cluster: local N workers, or the scheduler's address
    wall_s: float  # this invocation, start to end


def _rates(rows: Sequence[dict[str, Any]], keys: Callable[[dict[str, Any]], Iterable[str]]
           ) -> tuple[Rate, ...]:
    runs: Counter[str] = Counter()
    passed: Counter[str] = Counter()
    for row in rows:
        for key in dict.fromkeys(keys(row)):  # a kind twice in a run counts once
            runs[key] += 1
            passed[key] += bool(row["passed"])
    return tuple(Rate(k, runs[k], passed[k]) for k in sorted(runs))


def _kinds(row: dict[str, Any]) -> list[str]:
    return list(row["fault_kinds"]) or [CLEAN]


def _kind_stats(rows: Sequence[dict[str, Any]]) -> tuple[KindStats, ...]:
    out = []
    for rate in _rates(rows, _kinds):
        expected: Counter[str] = Counter()
        observed: Counter[str] = Counter()
        reactions: list[float | None] = []
        for row in rows:
            for i, kind in enumerate(row["fault_kinds"]):
                if kind != rate.group or i >= len(row["expected"]):
                    continue
                expected[row["expected"][i]] += 1
                observed[row["observed"][i]] += 1
                reactions.append(row["reaction_s"][i])
        out.append(KindStats(rate, " / ".join(expected) or "-",
                             tuple(observed.most_common()), Percentiles.of(reactions)))
    return tuple(out)


def _why(row: dict[str, Any]) -> str:
    if row["faults"] and not row["handled"]:
        wrong = [f"{spec}: expected {exp}, observed {obs}"
                 for spec, exp, obs, ok in zip(row["faults"], row["expected"],
                                               row["observed"], row["fault_handled"],
                                               strict=False) if not ok]
        if row["crashed"]:
            wrong.append("crashed")
        if wrong:
            return "; ".join(wrong) + (f" (end state {row['end_state']})"
                                       if row["end_state"] else "")
    return str(row["reason"] or row["verdict"] or row["result"])


def _version(row: dict[str, Any]) -> str:
    return row.get("code_version") or UNKNOWN_VERSION


def summarize(rows: Sequence[dict[str, Any]]) -> CampaignSummary:
    """The figures of a campaign's rows (:data:`~quadmission.campaigns.results.SCHEMA`)."""
    errors = [e for row in rows for e in row["touchdown_errors_m"]]
    return CampaignSummary(
        runs=len(rows), passed=sum(bool(r["passed"]) for r in rows),
        requeued=sum(r["attempts"] > 1 for r in rows),
        by_kind=_kind_stats(rows),
        by_lighting=_rates(rows, lambda r: [r["lighting"]]),
        by_scenario=_rates(rows, lambda r: [r["scenario"]]),
        landings=sum(r["landings"] or 0 for r in rows),
        landings_inside=sum(r["landings_inside"] or 0 for r in rows),
        touchdown_m=Percentiles.of(errors),
        wall_s=Percentiles.of(r["wall_s"] for r in rows),
        wall_total_s=float(sum(r["wall_s"] for r in rows)),
        cpu_total_s=float(sum(r["cpu_s"] for r in rows)),
        failed=tuple(FailedRun(r["cell"], r["result"], _why(r), r["replay"], _version(r))
                     for r in rows if not r["passed"]),
        code_versions=tuple(Counter(_version(r) for r in rows).most_common()))


def _num(value: float | None, fmt: str = ".1f", scale: float = 1.0) -> str:
    return "-" if value is None else f"{value * scale:{fmt}}"


def _pct(rate: Rate) -> str:
    return f"{100.0 * rate.rate:.0f} % ({rate.passed}/{rate.runs})"


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def summary_json(summary: CampaignSummary, session: Session) -> str:
    """``summary.json``: :class:`Session` and :class:`CampaignSummary` field for field, with
    each group's pass rate and the runs per CPU-hour (strict JSON)."""
    def rated(rate: Rate) -> dict[str, Any]:
        return {**dataclasses.asdict(rate), "rate": rate.rate}

    body = dataclasses.asdict(summary)
    body["by_kind"] = [{**dataclasses.asdict(k), "rate": rated(k.rate)} for k in summary.by_kind]
    body["by_lighting"] = [rated(r) for r in summary.by_lighting]
    body["by_scenario"] = [rated(r) for r in summary.by_scenario]
    body["rate"] = rated(Rate("all", summary.runs, summary.passed))
    body["runs_per_cpu_hour"] = summary.runs_per_cpu_hour
    return json.dumps({"session": dataclasses.asdict(session), "summary": body}, indent=1,
                      allow_nan=False) + "\n"


def _code_line(versions: Sequence[tuple[str, int]]) -> str:
    listed = ", ".join(f"`{v}` ({n} run{'s' * (n != 1)})" for v, n in versions)
    if len(versions) <= 1:
        return f"Code: {listed or '-'}."
    return (f"**Rows flown by {len(versions)} code versions**: {listed}. A resumed campaign "
            "keeps the rows it had; a run replays with its own row's code "
            "(`code_version` in results.parquet).")


def render_markdown(summary: CampaignSummary, session: Session,
                    pictures: Sequence[tuple[str, str]] = ()) -> str:
    """``summary.md``: the head, the tables, the pictures (``(caption, file)``), then
    every failed run with the line that replays it."""
    s, t = summary, summary.touchdown_m
    overall = Rate("all", s.runs, s.passed)
    lines = [
        f"# Campaign {session.name}", "",
        f"`{session.source}`: {session.cells} runs; {s.runs} finished "
        f"({session.ran} in this invocation, {session.skipped} before it, resumed)"
        + (f", **{session.lost} not finished**" if session.lost else "")
        + f"; on {session.where}, {session.wall_s:.0f} s of wall time.", "",
        _code_line(s.code_versions), "",
        f"**Passed: {_pct(overall)}.** A faulted run passes when it is handled (every "
        "fault's observed reaction the expected one, no crash, no error); a clean run "
        "when the scenario's own check passes. Re-queued after a lost worker: "
        f"{s.requeued} run(s).", "",
        "## Pass rate per fault kind", "",
        "| fault kind | passed | expected | observed (runs) | reaction p50 / p90 / max [s] |",
        "|---|---|---|---|---|",
    ]
    for k in s.by_kind:
        observed = ", ".join(f"{o} ({n})" for o, n in k.observed) or "-"
        r = k.reaction_s
        lines.append(f"| {k.rate.group} | {_pct(k.rate)} | {_cell(k.expected)} | "
                     f"{_cell(observed)} | {_num(r.p50, '.2f')} / {_num(r.p90, '.2f')} / "
                     f"{_num(r.max, '.2f')} |")
    lines += ["", "## Pass rate per lighting and per scenario", "",
              "| lighting | passed |", "|---|---|"]
    lines += [f"| {r.group} | {_pct(r)} |" for r in s.by_lighting]
    lines += ["", "| scenario | passed |", "|---|---|"]
    lines += [f"| {r.group} | {_pct(r)} |" for r in s.by_scenario]
    lines += ["", "## Touchdowns", ""]
    if t.n:
        lines.append(f"{s.landings_inside} of {s.landings} landings inside their pad; "
                     f"touchdown error p50 {_num(t.p50, '.1f', 100)} cm, p90 "
                     f"{_num(t.p90, '.1f', 100)} cm, p99 {_num(t.p99, '.1f', 100)} cm, max "
                     f"{_num(t.max, '.1f', 100)} cm (the true touchdown to the pad's centre).")
    else:
        lines.append("No landings on pads in these runs.")
    w = s.wall_s
    per_hour = s.runs_per_cpu_hour
    lines += ["", "## Time", "",
              f"Per run: p50 {_num(w.p50)} s, p90 {_num(w.p90)} s, max {_num(w.max)} s of "
              f"wall time; {s.wall_total_s:.0f} s of wall time and {s.cpu_total_s:.0f} s of "
              f"CPU time in all, {_num(per_hour, '.0f')} runs per CPU-hour.", ""]
    if pictures:
        lines += ["## Plots", ""]
        lines += [f"![{caption}]({name})" for caption, name in pictures]
        lines.append("")
    lines += ["## Failed runs", ""]
    if not s.failed:
        lines.append("None.")
    for f in s.failed:
        lines += [f"- `{f.cell}` (code `{f.code_version}`): {f.result}: {_cell(f.why)}", "",
                  "  ```sh", f"  {f.replay}", "  ```", ""]
    return "\n".join(lines).rstrip() + "\n"
