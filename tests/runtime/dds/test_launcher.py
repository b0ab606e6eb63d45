"""A DDS launch ends when a process dies, says which one, and stops the others."""

from __future__ import annotations

import io
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from runtime.dds.config import DdsConfig
from runtime.dds.launcher import process_specs, run_launch
from runtime.launch import LaunchDescription, NodeSpec


def test_a_dead_child_ends_the_launch_naming_it(dds_config: DdsConfig) -> None:
    description = LaunchDescription((
        NodeSpec("quadmission.examples:Listener", process="waiting"),  # waits for /clock
        NodeSpec("runtime.no_such_module:Node", process="broken"),
    ))
    specs = process_specs(description, domain_id=dds_config.domain_id, config_dir=None,
                          startup_timeout_s=60.0)
    assert [s.name for s in specs] == ["waiting", "broken"]
    log = io.StringIO()
    result = run_launch(specs, log=log)
    assert result.exit_code == 1
    assert "process 'broken'" in result.reason and "died" in result.reason
    assert "started waiting" in log.getvalue()  # and it was stopped: run_launch returned


def test_ctrl_c_stops_every_process_and_exits_130(dds_config: DdsConfig) -> None:
    root = Path(__file__).resolve().parents[3]
    proc = subprocess.Popen(
        [sys.executable, "-m", "quadmission.cli", "launch", "config/launch/example.yaml",
         "--transport", "dds", "--domain-id", str(dds_config.domain_id)],
        cwd=root, stderr=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    assert proc.stderr is not None
    pids = []
    for line in proc.stderr:
        if line.startswith("launch: started "):
            pids.append(int(line.rsplit("pid ", 1)[1].rstrip(")\n")))
        if len(pids) == 2:  # talker and listener, each in its own process
            break
    proc.send_signal(signal.SIGINT)
    assert proc.wait(30) == 130
    for pid in pids:  # the children are gone, not orphaned
        with pytest.raises(ProcessLookupError):
            os.kill(pid, 0)
