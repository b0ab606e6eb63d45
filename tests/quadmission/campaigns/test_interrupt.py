"""A campaign stopped by a signal writes what finished, whatever started it: SIGTERM (a
service manager, a cluster's job scheduler), and SIGINT where the shell that started it in
the background (`quadmission campaign ... &`) set SIGINT to be ignored, as shells do."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from quadmission.campaigns.runner import SUMMARY_JSON_NAME

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[3]
CAMPAIGN = """
name: stopped
timeout_s: 600
matrix:
  - scenarios: square
    seeds: [2, 7]
    lighting: light
"""


def _ignore_sigint() -> None:  # as a non-interactive shell does for `cmd &`
    signal.signal(signal.SIGINT, signal.SIG_IGN)


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
def test_a_signal_stops_the_campaign_and_its_summary_is_written(tmp_path: Path,
                                                               sig: signal.Signals) -> None:
    source = tmp_path / "stopped.yaml"
    source.write_text(CAMPAIGN)
    out = tmp_path / "out"
    log = tmp_path / "campaign.log"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p))
    with log.open("w") as f:
        proc = subprocess.Popen(
            [sys.executable, "-m", "quadmission.cli", "campaign", str(source), "--out",
             str(out), "--workers", "1", "--no-progress"], cwd=ROOT, stdout=f,
            stderr=subprocess.STDOUT, env=env, preexec_fn=_ignore_sigint)
    try:
        deadline = time.monotonic() + 180.0  # a loaded machine: the cluster's start
        while "running on" not in log.read_text():
            assert proc.poll() is None, log.read_text()
            assert time.monotonic() < deadline, log.read_text()
            time.sleep(0.2)
        proc.send_signal(sig)
        code = proc.wait(120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert code == 130, log.read_text()  # interrupted
    assert "interrupted" in log.read_text()
    summary = json.loads((out / SUMMARY_JSON_NAME).read_text())
    assert summary["session"]["cells"] == 2
    assert summary["session"]["ran"] + summary["session"]["lost"] == 2
