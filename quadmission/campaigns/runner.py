"""Running a campaign on Dask distributed, resuming, and writing its results.

:func:`run_campaign` submits every cell not finished yet (one Dask task a cell, which
runs ``quadmission sim`` in a child process: :mod:`quadmission.campaigns.process`) to a
``LocalCluster`` of worker processes (the default: one worker a core, one thread a
worker) or to an existing cluster by its scheduler's address. As each run ends, its row
is written to ``DIR/cells/<key>.json`` (so a campaign stopped anywhere resumes where it
was: the same command skips finished cells), and the progress bar moves. Then
``DIR/results.parquet``, ``DIR/summary.md`` and the plots are rebuilt from every
finished row of the campaign.

A worker lost mid-run (killed, out of memory, its machine gone) is Dask's to handle: the
scheduler re-queues its task on another worker, up to ``distributed.scheduler.allowed-
failures`` times (3), and a task that raises is retried :data:`RETRIES` times. Each
attempt announces itself as it starts (a Dask event on :data:`EVENT_TOPIC`), so a row's
``attempts`` counts them and the summary the runs re-queued. A cell lost more often than
that is reported as not finished, and the next invocation runs it again.
"""

from __future__ import annotations

import logging
import os
import sys
import threading
import time
import uuid
from collections import Counter
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from quadmission.campaigns.matrix import Campaign, Cell
from quadmission.campaigns.plots import PICTURES, save_plots
from quadmission.campaigns.process import run_cell
from quadmission.campaigns.results import RESULTS_NAME, CellStore, write_parquet
from quadmission.campaigns.summary import (
    CampaignSummary,
    Session,
    render_markdown,
    summarize,
    summary_json,
)
from quadmission.errors import CampaignError

__all__ = ["EVENT_TOPIC", "RETRIES", "SUMMARY_JSON_NAME", "SUMMARY_NAME", "CampaignResult",
           "run_campaign"]

EVENT_TOPIC = "quadmission-campaign"  # each attempt of a cell: {session, cell, worker, pid}
RETRIES = 2  # a task that raised (not a run that failed: that is a result) runs again
SUMMARY_NAME = "summary.md"
SUMMARY_JSON_NAME = "summary.json"  # the same figures for programs (benchmarks/results/)
CONNECT_TIMEOUT_S = 30.0  # s to reach a scheduler given by address


def _cell_task(cell: Cell, out: str, timeout_s: float, session: str) -> dict[str, Any]:
    """A campaign's Dask task: announce the attempt, fly the cell, return its row."""
    from distributed import get_worker

    worker = get_worker()
    worker.log_event(EVENT_TOPIC, {"session": session, "cell": cell.key,
                                   "worker": worker.address, "pid": os.getpid()})
    return run_cell(cell, Path(out), timeout_s, worker=str(worker.address))


@dataclass(frozen=True)
class CampaignResult:
    """What a campaign invocation leaves: the rows of every finished cell, their summary,
    what this invocation did, and the cells it could not finish."""

    out: Path
    rows: tuple[dict[str, Any], ...]
    summary: CampaignSummary
    session: Session
    lost: tuple[str, ...]


@contextmanager
def _client(workers: int | None, scheduler: str | None) -> Iterator[tuple[Any, str]]:
    """A Dask client: on the cluster at ``scheduler``, else on a new local cluster of
    ``workers`` processes (default: one a core), closed afterwards."""
    from distributed import Client, LocalCluster

    if scheduler is not None:
        try:
            client = Client(scheduler, timeout=CONNECT_TIMEOUT_S)
        except (OSError, TimeoutError) as exc:
            raise CampaignError(f"--scheduler {scheduler}: no Dask scheduler answers there "
                                f"({exc})") from None
        with client:
            n = len(client.scheduler_info(n_workers=-1)["workers"])
            yield client, f"the cluster at {scheduler} ({n} workers when it started)"
        return
    n = workers or os.cpu_count() or 1
    with LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                      dashboard_address=":0", silence_logs=logging.ERROR) as cluster, \
            Client(cluster) as client:
        yield client, f"a local cluster of {n} worker processes"


class _Attempts:
    """Counts each cell's attempts in this session from the workers' events."""

    def __init__(self, session: str) -> None:
        self.session = session
        self.count: Counter[str] = Counter()
        self._lock = threading.Lock()

    def __call__(self, event: tuple[float, Any]) -> None:
        _, msg = event
        if isinstance(msg, dict) and msg.get("session") == self.session:
            with self._lock:
                self.count[msg["cell"]] += 1

    def of(self, key: str) -> int:
        with self._lock:
            return max(1, self.count[key])


def _submit_all(client: Any, todo: list[Cell], out: Path, campaign: Campaign, store: CellStore,
                session: str, progress: bool, say: Callable[[str], None]) -> list[str]:
    """Run ``todo`` on ``client``; write each row as it comes; return the lost cells."""
    from distributed import as_completed
    from tqdm import tqdm

    attempts = _Attempts(session)
    client.subscribe_topic(EVENT_TOPIC, attempts)
    futures = {client.submit(_cell_task, cell, str(out), campaign.timeout_s, session,
                             key=f"{cell.key}-{session}", pure=False, retries=RETRIES): cell
               for cell in todo}
    lost: list[str] = []
    passed = requeued = 0
    try:
        with tqdm(total=len(todo), desc=campaign.name, unit="run", file=sys.stderr,
                  disable=not progress, dynamic_ncols=True) as bar:
            for future in as_completed(futures):
                cell = futures[future]
                try:
                    row = future.result()
                except Exception as exc:  # lost too often, or raised RETRIES + 1 times
                    lost.append(cell.key)
                    bar.write(f"LOST {cell.key}: {type(exc).__name__}: {exc}")
                    bar.update(1)
                    continue
                row["attempts"] = attempts.of(cell.key)
                store.put(row)
                passed += bool(row["passed"])
                requeued += row["attempts"] > 1
                if not row["passed"]:
                    bar.write(f"FAILED {cell.key}: {row['result']}: "
                              f"{row['reason'] or row['verdict']}")
                bar.set_postfix(passed=passed, requeued=requeued, refresh=False)
                bar.update(1)
    finally:
        client.unsubscribe_topic(EVENT_TOPIC)
        unfinished = [f for f in futures if not f.done()]
        if unfinished:  # interrupted: the runs go too
            client.cancel(unfinished)
    if lost:
        say(f"{len(lost)} run(s) not finished; the same command runs them again")
    return lost


def write_outputs(campaign: Campaign, out: Path, session: Session,
                  lost: tuple[str, ...] = ()) -> CampaignResult:
    """Rebuild ``results.parquet``, ``summary.md``, ``summary.json`` and the plots from the
    finished rows."""
    rows = CellStore(out).rows(campaign.cells)
    write_parquet(rows, out / RESULTS_NAME)
    summary = summarize(rows)
    save_plots(summary, rows, out)
    (out / SUMMARY_NAME).write_text(render_markdown(summary, session, PICTURES))
    (out / SUMMARY_JSON_NAME).write_text(summary_json(summary, session))
    return CampaignResult(out, tuple(rows), summary, session, lost)


def run_campaign(campaign: Campaign, out: Path, *, source: str, workers: int | None = None,
                 scheduler: str | None = None, progress: bool = True,
                 say: Callable[[str], None] = lambda _line: None) -> CampaignResult:
    """Run the cells of ``campaign`` not finished in ``out`` yet, then write its results.
    ``source``: the campaign file, for the summary. Interrupted (Ctrl-C), it still writes
    the results of the runs that finished, then raises."""
    out = out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    store = CellStore(out)
    done = store.done(campaign.cells)
    todo = [c for c in campaign.cells if c.key not in done]
    started = time.monotonic()
    say(f"campaign {campaign.name}: {len(campaign.cells)} runs, {len(done)} already "
        f"finished in {out}, {len(todo)} to run")
    lost: list[str] = []
    where = "nothing (every run had finished)"
    try:
        if todo:
            with _client(workers, scheduler) as (client, where):
                say(f"running on {where}")
                lost = _submit_all(client, todo, out, campaign, store, uuid.uuid4().hex[:12],
                                   progress, say)
    finally:
        finished = store.done(campaign.cells)
        session = Session(campaign.name, source, len(campaign.cells), skipped=len(done),
                          ran=len(finished) - len(done),
                          lost=len(campaign.cells) - len(finished), where=where,
                          wall_s=time.monotonic() - started)
        result = write_outputs(campaign, out, session, tuple(lost))
    return result
