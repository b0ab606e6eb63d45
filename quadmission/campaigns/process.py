"""One cell, flown: ``quadmission sim`` in a child process, measured and judged (no Dask).

A cell runs as its own process rather than as a function call inside the worker:

- a run that dies (a segfault in a native library, memory exhausted, a stuck loop past
  the campaign's ``timeout_s``) is that run's result (``error`` / ``timeout``), and the
  worker lives on to run the next cell; in process it would take the worker down and
  come back to Dask as a lost worker, re-queued up to three times for nothing;
- the process is exactly the replay line of the summary (``quadmission sim ...``, fresh
  interpreter, no state left by the cells before it): a failure replays as it failed;
- its CPU time is its own (``wait4``'s usage), whatever else the worker runs;
- one worker can run several cells at once (``dask worker --nthreads N``).

The price is the interpreter's start and imports, about 2 s of CPU a run: 1 % of a
mission, 10-20 % of the short square flights.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import quadmission
from quadmission.campaigns.matrix import Cell
from quadmission.campaigns.results import RUNS_DIR, RunOutcome, row_of
from quadmission.reports.report import REPORT_NAME

__all__ = ["LOG_NAME", "run_cell", "run_sim"]

LOG_NAME = "sim.log"  # the run's stdout and stderr, in its folder
POLL_S = 0.1  # s between looks at the running process
LOG_TAIL_BYTES = 2000


def _child_env() -> dict[str, str]:
    """This environment, with this checkout first on the path: the child flies the code
    this worker imported."""
    root = str(Path(quadmission.__file__).resolve().parents[1])
    path = os.environ.get("PYTHONPATH")
    return os.environ | {"PYTHONPATH": root if not path else root + os.pathsep + path,
                         "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}


def _wait(proc: subprocess.Popen[bytes], timeout_s: float) -> tuple[int | None, float]:
    """Wait for ``proc`` (kill it after ``timeout_s``): its exit code (None: killed at
    the limit) and its CPU seconds (user + system)."""
    deadline = time.monotonic() + timeout_s
    timed_out = False
    while True:
        pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
        if pid:
            break
        if time.monotonic() >= deadline:
            proc.kill()
            timed_out = True
            pid, status, usage = os.wait4(proc.pid, 0)
            break
        time.sleep(POLL_S)
    proc.returncode = os.waitstatus_to_exitcode(status)  # reaped here, not by Popen
    return None if timed_out else proc.returncode, usage.ru_utime + usage.ru_stime


def _tail(path: Path) -> str:
    with path.open("rb") as f:
        f.seek(max(0, path.stat().st_size - LOG_TAIL_BYTES))
        return f.read().decode(errors="replace")


def run_sim(args: list[str], run_dir: Path, timeout_s: float) -> RunOutcome:
    """Run ``quadmission ARGS`` (whose ``--out`` is ``run_dir``) in a child process that
    dies with this one; its log goes to ``run_dir/sim.log``."""
    cmd = [sys.executable, "-m", "quadmission.campaigns.child", str(os.getpid()), *args]
    log = run_dir / LOG_NAME
    started = time.monotonic()
    with log.open("wb") as out:
        proc = subprocess.Popen(cmd, stdout=out, stderr=subprocess.STDOUT,
                                stdin=subprocess.DEVNULL, env=_child_env())
        try:
            exit_code, cpu_s = _wait(proc, timeout_s)
        except BaseException:
            proc.kill()  # interrupted: the run goes with us
            raise
    wall_s = time.monotonic() - started
    report_path = run_dir / REPORT_NAME
    report = json.loads(report_path.read_text()) if report_path.is_file() else None
    return RunOutcome(exit_code, wall_s, cpu_s, report, _tail(log))


def run_cell(cell: Cell, out: Path, timeout_s: float, *, worker: str = "local",
             attempts: int = 1) -> dict[str, object]:
    """Fly ``cell`` into ``out/runs/<key>`` (emptied first: a re-queued run starts
    clean) and return its row (:func:`~quadmission.campaigns.results.row_of`)."""
    run_dir = out / RUNS_DIR / cell.key
    shutil.rmtree(run_dir, ignore_errors=True)
    run_dir.mkdir(parents=True)
    outcome = run_sim(cell.sim_args(run_dir), run_dir, timeout_s)
    return row_of(cell, outcome, run_dir=run_dir, worker=worker, attempts=attempts)
