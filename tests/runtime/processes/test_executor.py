"""The executor of a node process on the wall clock (runtime/processes/executor.py): a
timer that ran late skips the periods it missed, as rcl's timers do, instead of firing a
burst to catch up; and a process made long after its executor counts its timers from the
host's time. Real transport (rclpy on Fast DDS), no wall-clock figure asserted beyond the
delays the test itself makes."""

from __future__ import annotations

import itertools
import time
from collections.abc import Iterator

import pytest

from runtime import Node
from runtime.processes.executor import ClockedExecutor
from tests.runtime.processes.conftest import make_transport, needs_ros2

PERIOD_S = 0.01
BLOCK_S = 0.1  # ten periods


@pytest.fixture
def executor(domain_id: int) -> Iterator[ClockedExecutor]:
    ex = ClockedExecutor(make_transport("ros2", domain_id, "wall"), use_sim_time=False,
                         config_dir=None)
    try:
        yield ex
    finally:
        ex.process_transport.close()


@needs_ros2
def test_a_timer_late_by_ten_periods_fires_once_not_ten_times(
        executor: ClockedExecutor) -> None:
    node = Node("ticking", context=executor.context)
    ticks: list[int] = []  # the executor's clock at each call: its due time [ns]
    node.create_timer(PERIOD_S, lambda: ticks.append(executor.now_ns()))
    blocker = node.create_timer(0.025, lambda: (time.sleep(BLOCK_S), blocker.cancel()))
    deadline = time.monotonic() + 0.4
    while time.monotonic() < deadline:
        executor.spin_once_realtime()
    period_ns = round(PERIOD_S * 1e9)
    steps = [b - a for a, b in itertools.pairwise(ticks)]
    assert all(s % period_ns == 0 for s in steps), steps  # on its grid, no drift
    assert max(steps) >= round(BLOCK_S * 1e9) - period_ns, steps  # the blocked periods skipped
    assert len(ticks) < round(0.4 / PERIOD_S) - 5  # ... not run in a burst afterwards


@needs_ros2
def test_timers_count_from_the_hosts_time_once_caught_up(executor: ClockedExecutor) -> None:
    time.sleep(0.3)  # the imports of a process's nodes, between its executor and its nodes
    executor.catch_up()
    made_ns = time.time_ns()
    ticks: list[int] = []
    Node("late_made", context=executor.context).create_timer(
        PERIOD_S, lambda: ticks.append(executor.now_ns()))
    while len(ticks) < 3:
        executor.spin_once_realtime()
    assert ticks[0] >= made_ns  # not 30 periods due at once from the executor's birth
    assert ticks[1] - ticks[0] == round(PERIOD_S * 1e9)
