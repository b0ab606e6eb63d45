"""The lockstep's messages and reports (runtime/processes/lockstep.py, the clocked
executor's report_reached): the 12-byte Clock codec against the typestore's, and a node
process's reports on the real transport, one per period it passes and one at once for a
/clock sent again."""

from __future__ import annotations

import time
from collections.abc import Callable

from hypothesis import given
from hypothesis import strategies as st

import interfaces
from interfaces import graph
from runtime.clock import Time
from runtime.processes.child import ProcessSpec
from runtime.processes.executor import ClockedExecutor, ProcessTransport
from runtime.processes.lockstep import clock_cdr, clock_ns
from runtime.transport import Endpoint
from tests.runtime.processes.conftest import make_transport

_MAX_NS = (2**31 - 1) * 1_000_000_000 + 999_999_999  # int32 seconds


def _typestore_cdr(t_ns: int, little_endian: bool = True) -> bytes:
    msg = interfaces.new(graph.CLOCK.type, clock=Time(t_ns).to_msg())
    return bytes(interfaces.typestore().serialize_cdr(msg, graph.CLOCK.type,
                                                      little_endian=little_endian))


@given(st.integers(0, _MAX_NS))
def test_clock_bytes_are_the_typestores_and_read_back(t_ns: int) -> None:
    assert clock_cdr(t_ns) == _typestore_cdr(t_ns)
    assert clock_ns(clock_cdr(t_ns)) == t_ns


@given(st.integers(0, _MAX_NS))
def test_a_big_endian_clock_from_a_foreign_writer_is_read_through_the_typestore(
        t_ns: int) -> None:
    data = _typestore_cdr(t_ns, little_endian=False)
    assert data[:4] != clock_cdr(0)[:4]
    assert clock_ns(data) == t_ns


def _spin(transports: list[ProcessTransport], done: Callable[[], bool], timeout_s: float,
          follower: ClockedExecutor) -> bool:
    deadline = time.monotonic() + timeout_s
    while not done() and time.monotonic() < deadline:
        follower.spin_once_realtime()
        for transport in transports:
            transport.wait(0.005)
            transport.dispatch()
    return done()


def _reached(follower: ClockedExecutor, t_ns: int) -> Callable[[], bool]:
    return lambda: follower.now_ns() >= t_ns


def test_a_node_process_reports_once_a_period_and_at_once_for_a_clock_sent_again(
        transport_kind: str, domain_id: int) -> None:
    """/clock every 1 ms, a report period of 2 ms: one report in each period the clock
    passes, not one per /clock (the simulator needs no more to keep its lead bound), and
    one more at once when the last /clock comes again (the simulator waiting for it)."""
    period_ns = 2_000_000
    sim = make_transport(transport_kind, domain_id, "test_simulator")
    process = ProcessSpec("follower", transport=transport_kind,
                          domain_id=domain_id).make_transport()
    follower = ClockedExecutor(process, config_dir=None)
    topic = graph.LAUNCH_CLOCK_REPORT
    follower.report_reached(process.create_writer(Endpoint(
        topic.name_for("follower"), topic.type, topic.qos, node="/launch_follower_clock")),
        period_ns / 1e9)
    follower.follow_clock()
    clock = sim.create_writer(Endpoint(graph.CLOCK.name, graph.CLOCK.type, graph.CLOCK.qos,
                                       node="/test_simulator"))
    reports: list[int] = []
    reader = sim.create_reader(
        Endpoint(topic.name_for("follower"), topic.type, topic.subscriber_qos,
                 node="/test_simulator"), lambda data, _id: reports.append(clock_ns(data)))
    try:
        assert _spin([sim], lambda: clock.matched_count() > 0 and reader.matched_count() > 0,
                     60.0, follower)
        last_ns = 10 * 1_000_000
        for t_ns in range(0, last_ns + 1, 1_000_000):
            clock.write(clock_cdr(t_ns))
            assert _spin([sim], _reached(follower, t_ns), 10.0, follower)
        assert _spin([sim], lambda: bool(reports) and max(reports) >= last_ns, 10.0, follower)
        periods = [r // period_ns for r in reports]
        # every period after the first (its report may predate the reader's match: lost)
        assert set(range(1, last_ns // period_ns + 1)) <= set(periods), reports
        assert len(periods) == len(set(periods)), f"more than one report a period: {reports}"
        before = len(reports)
        clock.write(clock_cdr(last_ns))  # the simulator waits: the same /clock again
        assert _spin([sim], lambda: len(reports) > before, 10.0, follower), reports
        assert reports[-1] >= last_ns
    finally:
        process.close()
        sim.close()
