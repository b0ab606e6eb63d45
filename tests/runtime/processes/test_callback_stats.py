"""Callback timing on the wall clock (runtime/processes/callback_stats.py): the log-scale
histogram against exact quantiles, the files a run's processes write and their merge, and a
node process on the real transport timing its takes, its callbacks' lateness and their run.
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

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


@given(st.lists(st.integers(2, 10**10), min_size=1, max_size=300),
       st.sampled_from([0.5, 0.9, 0.99, 1.0]))
@settings(max_examples=200, deadline=None)
def test_a_quantile_falls_within_one_bin_of_the_exact_one(values: list[int], q: float) -> None:
    h = Histogram()
    for v in values:
        h.add(v)
    exact = float(np.quantile(values, q, method="inverted_cdf"))
    got = h.quantile_ns(q)
    assert exact / BIN_RATIO <= got <= exact * BIN_RATIO
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


@needs_ros2
def test_a_node_process_times_its_takes_and_callbacks(domain_id: int) -> None:
    # Five messages wait in DDS for 0.5 s before the listener's process takes them at once;
    # its callback runs 20 ms, so the fifth starts at least 80 ms after it was taken.
    listening = ClockedExecutor(make_transport("ros2", domain_id, "listening"),
                                use_sim_time=False, config_dir=None)
    talking = ClockedExecutor(make_transport("ros2", domain_id, "talking"),
                              use_sim_time=False, config_dir=None)
    try:
        stats = listening.keep_callback_stats()
        heard: list[str] = []

        def slow(msg: object) -> None:
            heard.append(msg.data)  # type: ignore[attr-defined]
            time.sleep(0.02)

        listener = Node("listener", context=listening.context)
        sub = listener.create_subscription("std_msgs/msg/String", "/cs/chatter", slow,
                                           QoSProfile(depth=10))
        ticks: list[int] = []
        Node("ticker", context=listening.context).create_timer(0.05, lambda: ticks.append(1))
        pub = Node("talker", context=talking.context).create_publisher(
            "std_msgs/msg/String", "/cs/chatter", QoSProfile(depth=10))
        deadline = time.monotonic() + 60.0
        while not (pub.get_subscription_count() and sub.get_publisher_count()):
            assert time.monotonic() < deadline, "the two processes never matched"
            listening.spin_once_realtime()
            talking.spin_once_realtime()
        for i in range(5):
            pub.publish(interfaces.new("std_msgs/msg/String", data=f"m{i}"))
        time.sleep(0.5)
        while len(heard) < 5 or len(ticks) < 3:
            assert time.monotonic() < deadline, f"heard {heard}, {len(ticks)} ticks"
            listening.spin_once_realtime()
    finally:
        listening.process_transport.close()
        talking.process_transport.close()
    got = stats.summary_ms()
    assert heard == [f"m{i}" for i in range(5)]
    taken = got["listener"]["take_delay"]
    assert taken["n"] == 5 and taken["p50"] >= 500.0 / BIN_RATIO
    ran = got["listener"]["run"]
    assert ran["n"] == 5 and ran["p50"] >= 20.0 / BIN_RATIO
    assert got["listener"]["latency"]["max"] >= 80.0
    assert got["ticker"]["latency"]["n"] == len(ticks) and "take_delay" in got["ticker"]
    assert got["ticker"]["take_delay"]["n"] == 0  # a timer takes nothing
    simulated = ClockedExecutor(make_transport("ros2", domain_id, "simulated"),
                                use_sim_time=True, config_dir=None)
    try:
        with pytest.raises(ValueError, match="need the wall clock"):
            simulated.keep_callback_stats()
    finally:
        simulated.process_transport.close()
