"""A cell lost past the cluster's retries is reported as not finished, and the next run of
the same campaign flies it and only it.

The cell is lost the real way: its task raises on every attempt (its run folder cannot be
made: a file stands where it goes), 1 + RETRIES times on a local Dask cluster, while the
other cell finishes. Each run is cut at ``timeout_s`` (a row saying ``timeout``): what is
checked is which cells have rows, not how they flew, so the campaign takes seconds.
"""

from __future__ import annotations

from pathlib import Path

import pyarrow.parquet as pq
import pytest

from quadmission.campaigns.matrix import load_campaign
from quadmission.campaigns.results import CELLS_DIR, RESULTS_NAME, RUNS_DIR, CellStore
from quadmission.campaigns.runner import SUMMARY_NAME, run_campaign

pytestmark = pytest.mark.slow

CAMPAIGN = """
name: lost-cell
timeout_s: 2
matrix:
  - scenarios: square
    seeds: [2, 7]
    lighting: light
"""


def test_a_cell_lost_past_the_retries_is_not_finished_then_runs_on_resume(
        tmp_path: Path) -> None:
    source = tmp_path / "lost.yaml"
    source.write_text(CAMPAIGN)
    campaign = load_campaign(source)
    lost, kept = campaign.cells
    out = tmp_path / "out"
    blocker = out / RUNS_DIR / lost.key
    blocker.parent.mkdir(parents=True)
    blocker.write_text("not a folder")  # run_cell cannot make the run's folder: it raises

    first = run_campaign(campaign, out, source=str(source), workers=1, progress=False)

    assert first.lost == (lost.key,)
    assert (first.session.ran, first.session.lost, first.session.skipped) == (1, 1, 0)
    assert [r["cell"] for r in first.rows] == [kept.key]
    assert CellStore(out).done(campaign.cells) == {kept.key}
    assert first.rows[0]["result"] == "timeout" and first.rows[0]["attempts"] == 1
    assert [r["cell"] for r in pq.read_table(out / RESULTS_NAME).to_pylist()] == [kept.key]
    assert "**1 not finished**" in (out / SUMMARY_NAME).read_text()
    kept_row = (out / CELLS_DIR / f"{kept.key}.json").read_text()

    blocker.unlink()  # the cause cleared: the same command runs what is left
    again = run_campaign(load_campaign(source), out, source=str(source), workers=1,
                         progress=False)

    assert again.lost == ()
    assert (again.session.ran, again.session.lost, again.session.skipped) == (1, 0, 1)
    assert [r["cell"] for r in again.rows] == [lost.key, kept.key]  # the campaign's order
    assert (out / CELLS_DIR / f"{kept.key}.json").read_text() == kept_row  # not run again
    resumed = next(r for r in again.rows if r["cell"] == lost.key)
    assert resumed["result"] == "timeout" and resumed["attempts"] == 1
    assert (out / RUNS_DIR / lost.key).is_dir()
    assert len(pq.read_table(out / RESULTS_NAME).to_pylist()) == 2
    assert "not finished" not in (out / SUMMARY_NAME).read_text()
