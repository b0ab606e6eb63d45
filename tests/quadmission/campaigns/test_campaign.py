"""A campaign on a real Dask cluster: a scheduler and two worker processes on localhost,
four short faulted square flights, one worker killed mid-run. The rows in Parquet, the
summary, the re-queued run, its orphan-free kill, the replay line flying the same run
again, and resuming (shared: one campaign, about 30-60 s)."""

from __future__ import annotations

import json
import os
import shlex
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pyarrow.parquet as pq
import pytest
from distributed import Client, LocalCluster

from quadmission.campaigns.matrix import load_campaign
from quadmission.campaigns.process import LOG_NAME
from quadmission.campaigns.results import CELLS_DIR, RESULTS_NAME
from quadmission.campaigns.runner import (
    EVENT_TOPIC,
    SUMMARY_JSON_NAME,
    SUMMARY_NAME,
    CampaignResult,
    run_campaign,
)
from quadmission.cli import main
from quadmission.evaluation.faults import EXPECTED
from quadmission.reports.report import REPORT_NAME, code_version
from sim.fault_spec import FaultKind

pytestmark = pytest.mark.slow

# random arenas 2 and 7 have the smallest squares (2 m, 2.75 m: 35 s and 39 s flights);
# at 12 s the drone is on the square's first leg
CAMPAIGN = """
name: square-faults
timeout_s: 600
matrix:
  - scenarios: square
    seeds: [2, 7]
    lighting: light
    faults: [vio_stop@12:2, link_lost@12:3]
"""
REQUIRED = ["scenario", "seed", "lighting", "faults", "handled", "result", "wall_s"]


@pytest.fixture(scope="module")
def cluster() -> Iterator[LocalCluster]:
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=":0") as cluster:
        yield cluster


def _children_of(pid: int) -> list[int]:
    """The cell processes a worker started (their argv names the worker's pid)."""
    found = []
    for entry in Path("/proc").iterdir():
        try:
            argv = (entry / "cmdline").read_bytes().split(b"\0")
        except OSError:
            continue
        if b"quadmission.campaigns.child" in argv and str(pid).encode() in argv:
            found.append(int(entry.name))
    return found


@pytest.fixture(scope="module")
def flown(cluster: LocalCluster, tmp_path_factory: pytest.TempPathFactory
          ) -> tuple[CampaignResult, dict[str, Any], list[int], Path]:
    """The campaign, with the worker of the first run to start killed (SIGKILL) once its
    run is under way: (result, that run's start event, the cell processes still alive
    after the kill, the campaign file)."""
    folder = tmp_path_factory.mktemp("campaign")
    source = folder / "square.yaml"
    source.write_text(CAMPAIGN)
    box: dict[str, Any] = {}

    def campaign() -> None:
        box["result"] = run_campaign(load_campaign(source), folder / "out", source=str(source),
                                     scheduler=cluster.scheduler_address, progress=False)

    thread = threading.Thread(target=campaign)
    thread.start()
    with Client(cluster.scheduler_address) as client:
        deadline = time.monotonic() + 120
        while not client.get_events(EVENT_TOPIC) and time.monotonic() < deadline:
            time.sleep(0.05)
        first = client.get_events(EVENT_TOPIC)[0][1]
        deadline = time.monotonic() + 30
        while not _children_of(first["pid"]) and time.monotonic() < deadline:
            time.sleep(0.05)  # its flight has started
        os.kill(first["pid"], signal.SIGKILL)
        deadline = time.monotonic() + 10
        while _children_of(first["pid"]) and time.monotonic() < deadline:
            time.sleep(0.05)
        orphans = _children_of(first["pid"])
    thread.join(timeout=600)
    assert "result" in box, "the campaign did not finish"
    return box["result"], first, orphans, source


@pytest.fixture(scope="module")
def rows(flown: tuple[CampaignResult, dict[str, Any], list[int], Path]
         ) -> list[dict[str, Any]]:
    result = flown[0]
    return pq.read_table(result.out / RESULTS_NAME).to_pylist()


def test_every_cell_has_one_row_with_the_issues_columns(rows: list[dict[str, Any]]) -> None:
    assert all(name in rows[0] for name in REQUIRED)
    assert sorted((r["seed"], r["faults"][0]) for r in rows) == [
        (2, "link_lost@12:3"), (2, "vio_stop@12:2"), (7, "link_lost@12:3"),
        (7, "vio_stop@12:2")]
    for r in rows:
        assert (r["scenario"], r["lighting"], r["arena_name"]) == (
            "square", "light", f"random-{r['seed']}")
        assert r["result"] in ("landed", "crash", "failed"), r  # each run flew
        assert r["wall_s"] > 0 and r["cpu_s"] > 0 and r["sim_s"] > 12.0
        assert "report:" in (Path(r["run_dir"]) / LOG_NAME).read_text()
        assert r["code_version"] == code_version()  # the checkout the workers flew


def test_each_fault_is_judged_by_its_expected_reaction(rows: list[dict[str, Any]]) -> None:
    """The square has no mission: the FCU's failsafe catches a lost link, and nothing
    notices the VIO stopping, so those runs are not handled, whatever the flight did."""
    for r in rows:
        kind = FaultKind(r["fault_kinds"][0])
        report = json.loads((Path(r["run_dir"]) / REPORT_NAME).read_text())
        assert r["observed"] == [f["observed"] for f in report["faults"]]
        if kind is FaultKind.LINK_LOST:
            assert r["expected"] == ["FAILSAFE"] == r["observed"]
            assert 0.0 < r["reaction_s"][0] < 3.0
        else:
            assert r["expected"] == [f"{EXPECTED[kind].cause.value}: HOLD"]  # type: ignore[union-attr]
            assert r["observed"] == ["none"] and not r["handled"]
        assert r["handled"] == (not r["crashed"] and all(r["fault_handled"]))
        assert r["passed"] == r["handled"]


def test_the_lost_worker_s_run_was_requeued_counted_and_its_process_killed(
        flown: tuple[CampaignResult, dict[str, Any], list[int], Path],
        rows: list[dict[str, Any]]) -> None:
    result, first, orphans, _ = flown
    attempts = {r["cell"]: r["attempts"] for r in rows}
    assert attempts.pop(first["cell"]) == 2
    assert set(attempts.values()) == {1}
    assert result.summary.requeued == 1 and result.session.lost == 0
    assert orphans == [], "a killed worker's flight went on without it"
    killed = next(r for r in rows if r["cell"] == first["cell"])
    assert killed["worker"] != first["worker"]  # flown again by another worker process


def test_the_summary_gives_rates_and_every_failed_run_s_replay_line(
        flown: tuple[CampaignResult, dict[str, Any], list[int], Path],
        rows: list[dict[str, Any]]) -> None:
    text = (flown[0].out / SUMMARY_NAME).read_text()
    for kind in ("vio_stop", "link_lost"):
        mine = [r for r in rows if r["fault_kinds"] == [kind]]
        passed = sum(r["passed"] for r in mine)
        assert f"| {kind} | {100 * passed // len(mine)} % ({passed}/{len(mine)}) |" in text
    total = sum(r["passed"] for r in rows)
    assert f"| light | {100 * total // 4} % ({total}/4) |" in text
    assert "Re-queued after a lost worker: 1 run(s)" in text
    failed = text.split("## Failed runs")[1]
    for r in rows:
        assert (f"  {r['replay']}\n" in failed) is (not r["passed"])
        assert r["replay"].endswith(f"--out {shlex.quote(r['run_dir'])}")
    assert all((flown[0].out / name).stat().st_size > 0 for name in
               ("pass_rate.png", "touchdown_error.png", "reaction_time.png", "wall_time.png"))
    figures = json.loads((flown[0].out / SUMMARY_JSON_NAME).read_text())["summary"]
    assert figures["rate"] == {"group": "all", "runs": 4, "passed": total, "rate": total / 4}
    assert figures["code_versions"] == [[code_version(), 4]]


def test_the_replay_line_flies_the_same_run(rows: list[dict[str, Any]]) -> None:
    r = min(rows, key=lambda r: r["sim_s"])  # the shortest
    report_path = Path(r["run_dir"]) / REPORT_NAME
    before = json.loads(report_path.read_text())
    words = shlex.split(r["replay"])
    assert words[0] == "quadmission"
    done = subprocess.run([sys.executable, "-m", "quadmission.cli", *words[1:]],
                          capture_output=True, text=True, timeout=600, check=False)
    assert done.returncode == r["exit_code"], done.stderr[-2000:]
    after = json.loads(report_path.read_text())
    before.pop("host")
    after.pop("host")
    assert after == before


def test_running_it_again_skips_what_finished_and_runs_only_new_cells(
        flown: tuple[CampaignResult, dict[str, Any], list[int], Path],
        rows: list[dict[str, Any]], capsys: pytest.CaptureFixture[str]) -> None:
    result, _, _, source = flown
    cells = result.out / CELLS_DIR
    kept = {p.name: p.read_text() for p in cells.iterdir()}
    again = run_campaign(load_campaign(source), result.out, source=str(source),
                         scheduler="tcp://127.0.0.1:1", progress=False)  # never reached
    assert (again.session.ran, again.session.skipped) == (0, 4)
    assert again.rows == result.rows
    # one more cell: only it runs, on the embedded local cluster, through the CLI
    source.write_text(CAMPAIGN + "  - scenarios: square\n    seeds: [2]\n    lighting: dark\n")
    code = main(["campaign", str(source), "--out", str(result.out), "--workers", "1",
                 "--no-progress"])
    out = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert (out["runs"], out["finished"]) == (5, 5)
    assert code == (0 if out["passed"] == 5 else 1)
    assert {p.name: p.read_text() for p in cells.iterdir() if p.name in kept} == kept
    table = pq.read_table(result.out / RESULTS_NAME).to_pylist()
    new = [r for r in table if r["lighting"] == "dark"]
    assert len(table) == 5 and len(new) == 1 and new[0]["faults"] == []
    assert new[0]["passed"] == (new[0]["result"] == "landed")
