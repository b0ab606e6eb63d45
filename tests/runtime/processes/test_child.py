"""The lockstep between a launch's processes (runtime/processes/child.py), on the real
transport: a node process against a simulator played by the test, and a simulator
against a node process that never reports."""

from __future__ import annotations

import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import interfaces
from interfaces import graph
from runtime.clock import Time
from runtime.launch import LaunchDescription, NodeSpec
from runtime.processes.child import EXIT_STALLED, ProcessSpec
from runtime.processes.executor import ProcessTransport
from runtime.processes.launcher import process_specs
from runtime.transport import Endpoint
from tests.runtime.processes.conftest import make_transport

ROOT = Path(__file__).resolve().parents[3]


def _clock(t_ns: int) -> bytes:
    return interfaces.serialize(interfaces.new(graph.CLOCK.type, clock=Time(t_ns).to_msg()),
                                graph.CLOCK.type)


def _until(transport: ProcessTransport, done: Callable[[], bool], timeout_s: float) -> None:
    deadline = time.monotonic() + timeout_s
    while not done() and time.monotonic() < deadline:
        transport.wait(0.05)
        transport.dispatch()


def test_a_clock_sent_again_is_answered_with_a_report_when_the_first_ones_were_lost(
        transport_kind: str, domain_id: int, tmp_path: Path) -> None:
    """The simulator waits for a report that was written before its reader matched (lost:
    volatile) and sends the same /clock again; the process answers with its report. Its
    timer, on a simulated time that no longer moves, would not: a square launch on a
    loaded host stalled at 5 ms of simulated time for 15 minutes."""
    description = LaunchDescription((NodeSpec("quadmission.examples:Listener",
                                              process="follower"),))
    (spec,) = process_specs(description, transport=transport_kind, domain_id=domain_id,
                            config_dir=None, startup_timeout_s=60.0)
    sim = make_transport(transport_kind, domain_id, "test_simulator")
    clock = sim.create_writer(Endpoint(graph.CLOCK.name, graph.CLOCK.type, graph.CLOCK.qos,
                                       node="/test_simulator"))
    log = tmp_path / "follower.log"
    with log.open("w") as err:
        child = subprocess.Popen([sys.executable, "-m", "runtime.processes.child",
                                  spec.to_json()], cwd=ROOT, stderr=err)
    try:
        _until(sim, lambda: clock.matched_count() > 0, 60.0)
        assert clock.matched_count() > 0, log.read_text()
        for ms in range(6):  # 0-5 ms; its reports reach no reader (at 2, 4 and, a /clock
            # step ahead, 6 ms): then nothing moves its simulated time
            clock.write(_clock(ms * 1_000_000))
            _until(sim, lambda: False, 0.05)
        _until(sim, lambda: False, 1.0)  # it has taken them
        reports: list[int] = []
        topic = graph.LAUNCH_CLOCK_REPORT
        reader = sim.create_reader(
            Endpoint(topic.name_for("follower"), topic.type, topic.subscriber_qos,
                     node="/test_simulator"),
            lambda data, _id: reports.append(Time.from_msg(
                interfaces.deserialize(data, graph.CLOCK.type).clock).nanoseconds))
        _until(sim, lambda: reader.matched_count() > 0, 30.0)
        assert reader.matched_count() > 0
        deadline = time.monotonic() + 20.0
        while not reports and time.monotonic() < deadline:  # as the simulator waits
            clock.write(_clock(5_000_000))
            _until(sim, lambda: bool(reports), 0.1)
        assert reports, f"no report after /clock was sent again; {log.read_text()}"
        assert max(reports) >= 5_000_000  # where it had got to
    finally:
        _end(child)
        sim.close()


def _end(proc: subprocess.Popen[bytes]) -> None:
    proc.terminate()
    try:
        proc.wait(30)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


def test_a_simulator_waiting_on_a_silent_node_process_says_so_and_exits(
        transport_kind: str, domain_id: int) -> None:
    """A follower that never reports (here: none runs) stops the simulator after
    ``stall_timeout_s`` with a line that names it, instead of a silent wait."""
    spec = ProcessSpec("simulator", transport=transport_kind, domain_id=domain_id,
                       simulator={"factory": "tests.runtime.processes.lockstep_parts:world",
                                  "parameters": {}},
                       followers=("ghost",), stall_timeout_s=2.0, duration_s=10.0)
    out = subprocess.run([sys.executable, "-m", "runtime.processes.child", spec.to_json()],
                         cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert out.returncode == EXIT_STALLED, out.stderr
    assert "stalled at 0.00" in out.stderr and "no report from ghost (at 0.000 s) for 2 s" \
        in out.stderr
