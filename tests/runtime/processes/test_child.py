"""A node process of a launch (runtime/processes/child.py) against a simulator played by
the test, on the real transport: the lockstep reports it sends."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import interfaces
from interfaces.qos import QoSProfile
from runtime.clock import Time
from runtime.launch import LaunchDescription, NodeSpec
from runtime.processes.child import ack_topic
from runtime.processes.executor import CLOCK_TOPIC, CLOCK_TYPE
from runtime.processes.launcher import process_specs
from runtime.transport import Endpoint
from tests.runtime.processes.conftest import make_transport

ROOT = Path(__file__).resolve().parents[3]
QOS = QoSProfile(depth=1)  # the simulator's /clock writer and the reports: reliable, volatile


def _clock(t_ns: int) -> bytes:
    sec, nsec = divmod(t_ns, 1_000_000_000)
    return interfaces.serialize(interfaces.new(CLOCK_TYPE, clock=interfaces.new(
        "builtin_interfaces/msg/Time", sec=sec, nanosec=nsec)), CLOCK_TYPE)


def _until(transport: object, done: object, timeout_s: float) -> None:
    deadline = time.monotonic() + timeout_s
    while not done() and time.monotonic() < deadline:  # type: ignore[operator]
        transport.wait(0.05)  # type: ignore[attr-defined]
        transport.dispatch()  # type: ignore[attr-defined]


def test_a_clock_sent_again_is_answered_with_a_report_when_the_first_ones_were_lost(
        transport_kind: str, domain_id: int) -> None:
    """The simulator waits for a report that was written before its reader matched (lost:
    volatile) and sends the same /clock again; the process answers with its report. Its
    timer, on a simulated time that no longer moves, would not: a square launch on a
    loaded host stalled at 5 ms of simulated time for 15 minutes."""
    description = LaunchDescription((NodeSpec("quadmission.examples:Listener",
                                              process="follower"),))
    (spec,) = process_specs(description, transport=transport_kind, domain_id=domain_id,
                            config_dir=None, startup_timeout_s=60.0)
    sim = make_transport(transport_kind, domain_id, "test_simulator")
    clock = sim.create_writer(Endpoint(CLOCK_TOPIC, CLOCK_TYPE, QOS, node="/test_simulator"))
    child = subprocess.Popen([sys.executable, "-m", "runtime.processes.child", spec.to_json()],
                             cwd=ROOT, stderr=subprocess.PIPE, text=True)
    try:
        _until(sim, lambda: clock.matched_count() > 0, 60.0)
        assert clock.matched_count() > 0, "the node process never subscribed to /clock"
        for ms in range(6):  # 0-5 ms; its reports at 2 and 4 ms reach no reader
            clock.write(_clock(ms * 1_000_000))
            _until(sim, lambda: False, 0.05)
        _until(sim, lambda: False, 1.0)  # it has taken them
        reports: list[int] = []
        reader = sim.create_reader(
            Endpoint(ack_topic("follower"), CLOCK_TYPE, QOS, node="/test_simulator"),
            lambda data, _id: reports.append(Time.from_msg(
                interfaces.deserialize(data, CLOCK_TYPE).clock).nanoseconds))
        _until(sim, lambda: reader.matched_count() > 0, 30.0)
        assert reader.matched_count() > 0
        deadline = time.monotonic() + 20.0
        while not reports and time.monotonic() < deadline:  # as the simulator waits
            clock.write(_clock(5_000_000))
            _until(sim, lambda: bool(reports), 0.1)
        assert reports, "no report after /clock was sent again"
        assert max(reports) >= 4_000_000  # where it had got to
    finally:
        child.terminate()
        child.wait(30)
        sim.close()
