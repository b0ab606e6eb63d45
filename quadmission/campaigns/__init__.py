"""Campaigns: scenarios x seeds x faults x lighting, run on Dask distributed (issue 22).

Nothing is imported here, so that a cell's process (:mod:`.child`) starts light:
:mod:`.matrix` (the campaign file and its cells), :mod:`.results` (rows, resuming,
Parquet), :mod:`.summary` and :mod:`.plots` (summary.md and its PNGs), :mod:`.process`
(one cell as a child process) and :mod:`.runner` (Dask; :func:`.runner.run_campaign`).
"""

__all__ = ["child", "matrix", "plots", "process", "results", "runner", "summary"]
