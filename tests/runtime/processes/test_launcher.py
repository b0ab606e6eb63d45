"""A launch over processes ends when a process dies, says which one, and stops the others;
the simulator keeps in lockstep with a starved process. On both process transports."""

from __future__ import annotations

import io
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from runtime.launch import LaunchDescription, NodeSpec
from runtime.processes.launcher import process_specs, run_launch


def test_a_dead_child_ends_the_launch_naming_it(transport_kind: str, domain_id: int) -> None:
    description = LaunchDescription((
        NodeSpec("quadmission.examples:Listener", process="waiting"),  # waits for /clock
        NodeSpec("runtime.no_such_module:Node", process="broken"),
    ))
    specs = process_specs(description, transport=transport_kind, domain_id=domain_id,
                          config_dir=None,
                          startup_timeout_s=60.0)
    assert [s.name for s in specs] == ["waiting", "broken"]
    log = io.StringIO()
    result = run_launch(specs, log=log)
    assert result.exit_code == 1
    assert "process 'broken'" in result.reason and "died" in result.reason
    assert "started waiting" in log.getvalue()  # and it was stopped: run_launch returned


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_ctrl_c_stops_every_process_and_exits_130(transport_kind: str, domain_id: int,
                                                  sig: signal.Signals) -> None:
    root = Path(__file__).resolve().parents[3]
    proc = subprocess.Popen(
        [sys.executable, "-m", "quadmission.cli", "launch", "config/launch/example.yaml",
         "--transport", transport_kind, "--domain-id", str(domain_id)],
        cwd=root, stderr=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    assert proc.stderr is not None
    pids = []
    for line in proc.stderr:
        if line.startswith("launch: started "):
            pids.append(int(line.rsplit("pid ", 1)[1].rstrip(")\n")))
        if len(pids) == 2:  # talker and listener, each in its own process
            break
    proc.send_signal(sig)
    assert proc.wait(30) == 130
    for pid in pids:  # the children are gone, not orphaned
        with pytest.raises(ProcessLookupError):
            os.kill(pid, 0)


def test_the_simulator_never_runs_far_ahead_of_a_starved_process(
        transport_kind: str, domain_id: int, tmp_path: Path) -> None:
    # The node burns 20 ms of host time every 10 ms simulated; the world could run 100x
    # real time. In lockstep the world waits: it is never more than the bound (plus a
    # report's way) ahead of the node, which is what keeps a starved bridge's time sync
    # valid. At the old 0.25 s bound the lead reached about 0.25 s.
    from runtime.processes.child import ProcessSpec
    from tests.runtime.processes.lockstep_parts import SLOW_PERIOD_S

    launch_file = tmp_path / "lockstep.yaml"
    launch_file.write_text(
        "simulator:\n  factory: tests.runtime.processes.lockstep_parts:world\n"
        "nodes:\n  - factory: tests.runtime.processes.lockstep_parts:SlowNode\n", encoding="utf-8")
    root = Path(__file__).resolve().parents[3]
    out = subprocess.run(
        [sys.executable, "-m", "quadmission.cli", "launch", str(launch_file), "--transport",
         transport_kind, "--domain-id", str(domain_id), "--rtf", "100", "--duration", "1"],
        cwd=root, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-3000:]
    line = next(s for s in out.stderr.splitlines() if s.startswith("[simulator] max lead "))
    lead_ns, reports = int(line.split()[3]), int(line.split()[6])
    assert reports >= 0.5 / SLOW_PERIOD_S, line  # the node ran through the second
    bound = ProcessSpec("x").max_lead_s
    assert lead_ns <= round(2 * bound * 1e9), line
