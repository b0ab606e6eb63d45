"""Callback timing on the wall clock (runtime/processes/callback_stats.py): the log-scale
histogram against exact quantiles, the files a run's processes write and their merge, and a
node process on the real transport timing its takes, its callbacks' lateness and their run.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import interfaces
from interfaces.qos import QoSProfile
from runtime import Node
from runtime.processes.callback_stats import (
    BINS_PER_OCTAVE,
    STATS_VARIABLE,
    CallbackStats,
    Histogram,
    merge,
    stats_folder,
)
from runtime.processes.executor import ClockedExecutor
from tests.runtime.processes.conftest import make_transport, needs_ros2

BIN_RATIO = 2.0 ** (1.0 / BINS_PER_OCTAVE)  # a bin's width, as a factor
HALF_BIN = 2.0 ** (0.5 / BINS_PER_OCTAVE) * 1.0001  # a bin's middle from either edge


@given(st.lists(st.integers(2, 10**10), min_size=1, max_size=300),
       st.sampled_from([0.5, 0.9, 0.99, 1.0]))
@settings(max_examples=200, deadline=None)
def test_a_quantile_falls_within_half_a_bin_of_the_exact_one(values: list[int],
                                                              q: float) -> None:
    h = Histogram()
    for v in values:
        h.add(v)
    exact = float(np.quantile(values, q, method="inverted_cdf"))
    got = h.quantile_ns(q)
    assert exact / HALF_BIN <= got <= exact * HALF_BIN
    assert got <= max(values)
    assert h.count == len(values) and h.max_ns == max(values)


def test_an_empty_histogram_has_no_quantiles_and_a_bad_one_is_refused() -> None:
    h = Histogram()
    assert math.isnan(h.quantile_ns(0.5))
    assert h.summary_ms() == {"n": 0, "p50": None, "p99": None, "max": None}
    with pytest.raises(ValueError, match=r"quantile 1.5 is outside 0\.\.1"):
        h.quantile_ns(1.5)


def test_the_files_of_a_respawned_process_merge_per_node(tmp_path: Path) -> None:
    first, second = CallbackStats(), CallbackStats()
    for _ in range(99):
        first.callback("navigator", latency_ns=1_000_000, run_ns=2_000_000)
    second.callback("navigator", latency_ns=400_000_000, run_ns=2_000_000)
    second.take("mapping", 5_000_000)
    path = second.write(tmp_path, "navigation")
    path = path.rename(tmp_path / "navigation.1.json")  # another pid: the respawned one
    first.write(tmp_path, "navigation")
    merged = merge(tmp_path)
    nav = merged["navigator"]
    assert nav["process"] == "navigation"
    assert nav["latency"]["n"] == 100 and nav["latency"]["max"] == 400.0
    assert nav["latency"]["p50"] == pytest.approx(1.0, rel=0.1)
    assert nav["latency"]["p99"] == pytest.approx(1.0, rel=0.1)  # 99 of 100 at 1 ms
    assert merged["mapping"]["take_delay"]["n"] == 1
    assert json.loads(path.read_text())["process"] == "navigation"


def test_the_folder_comes_from_the_environment(monkeypatch: pytest.MonkeyPatch,
                                               tmp_path: Path) -> None:
    monkeypatch.setenv(STATS_VARIABLE, str(tmp_path))
    assert stats_folder() == tmp_path
    monkeypatch.setenv(STATS_VARIABLE, " ")
    assert stats_folder() is None


@dataclass
class Timed:
    """A process timing its callbacks (``listening``) and one that talks to it."""

    listening: ClockedExecutor
    talking: ClockedExecutor
    stats: CallbackStats

    def chatter(self, listener: Node, topic: str,
                callback: Callable[[Any], None]) -> Any:
        """``listener`` subscribed to ``topic`` and a talker's publisher, matched."""
        sub = listener.create_subscription("std_msgs/msg/String", topic, callback,
                                           QoSProfile(depth=10))
        pub = Node("talker", context=self.talking.context).create_publisher(
            "std_msgs/msg/String", topic, QoSProfile(depth=10))
        self.spin_until(lambda: bool(pub.get_subscription_count()
                                     and sub.get_publisher_count()), both=True)
        return pub

    def spin_until(self, done: Callable[[], bool], *, both: bool = False) -> None:
        deadline = time.monotonic() + 60.0  # a loaded machine
        while not done():
            assert time.monotonic() < deadline, "not done after 60 s"
            self.listening.spin_once_realtime()
            if both:
                self.talking.spin_once_realtime()


@pytest.fixture
def timed(domain_id: int) -> Iterator[Timed]:
    listening = ClockedExecutor(make_transport("ros2", domain_id, "listening"),
                                use_sim_time=False, config_dir=None)
    talking = ClockedExecutor(make_transport("ros2", domain_id, "talking"),
                              use_sim_time=False, config_dir=None)
    try:
        yield Timed(listening, talking, listening.keep_callback_stats())
    finally:
        listening.process_transport.close()
        talking.process_transport.close()


@needs_ros2
def test_a_node_process_times_its_takes_and_callbacks(timed: Timed) -> None:
    # Five messages wait in DDS for 0.5 s before the listener's process takes them at once;
    # its callback runs 20 ms, so the fifth starts at least 80 ms after it was taken.
    heard: list[str] = []

    def slow(msg: Any) -> None:
        heard.append(msg.data)
        time.sleep(0.02)

    pub = timed.chatter(Node("listener", context=timed.listening.context), "/cs/chatter", slow)
    ticks: list[int] = []
    Node("ticker", context=timed.listening.context).create_timer(0.05, lambda: ticks.append(1))
    for i in range(5):
        pub.publish(interfaces.new("std_msgs/msg/String", data=f"m{i}"))
    time.sleep(0.5)
    timed.spin_until(lambda: len(heard) == 5 and len(ticks) >= 3)
    listener, ticker = timed.stats.nodes["listener"], timed.stats.nodes["ticker"]
    assert heard == [f"m{i}" for i in range(5)]
    assert listener["take_delay"].count == 5
    assert listener["take_delay"].quantile_ns(0.5) >= 0.5e9 / BIN_RATIO
    assert listener["run"].count == 5 and listener["run"].quantile_ns(0.5) >= 0.02e9 / BIN_RATIO
    assert listener["latency"].max_ns >= 80_000_000
    assert ticker["latency"].count == len(ticks)
    assert ticker["take_delay"].count == 0  # a timer takes nothing


@needs_ros2
def test_a_message_waiting_behind_a_long_callback_is_counted_once(timed: Timed) -> None:
    # A message arrives while another node's 100 ms callback runs: it waits in DDS until the
    # process takes it (take delay), then starts at once (latency ~0). The two add up to its
    # whole wait, not twice the blocking callback.
    started: list[int] = []
    pub = timed.chatter(Node("listener", context=timed.listening.context), "/cs/once",
                        lambda _m: started.append(time.time_ns()))
    def block() -> None:
        time.sleep(0.1)
        once.cancel()

    once = Node("blocker", context=timed.listening.context).create_timer(0.001, block)
    sent_ns = time.time_ns()
    pub.publish(interfaces.new("std_msgs/msg/String", data="late"))
    time.sleep(0.02)  # delivered, and the blocker due: it runs before the take
    timed.spin_until(lambda: bool(started))
    listener = timed.stats.nodes["listener"]
    taken, late = listener["take_delay"].max_ns, listener["latency"].max_ns
    assert taken >= 100_000_000  # in DDS while the blocker ran
    assert taken + late <= started[0] - sent_ns + 1_000_000


@needs_ros2
def test_a_simulated_clock_has_no_callback_timing(domain_id: int) -> None:
    simulated = ClockedExecutor(make_transport("ros2", domain_id, "simulated"),
                                use_sim_time=True, config_dir=None)
    try:
        with pytest.raises(ValueError, match="need the wall clock"):
            simulated.keep_callback_stats()
    finally:
        simulated.process_transport.close()
