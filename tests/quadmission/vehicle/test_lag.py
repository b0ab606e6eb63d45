"""The lag monitor: when a paced world is behind real time, by how much, how often."""

from __future__ import annotations

import pytest

from quadmission.vehicle.lag import LagMonitor


def test_keeping_up_says_nothing_and_counts_nothing() -> None:
    m = LagMonitor(threshold_s=0.05)
    assert [m.update(t * 0.01, 0.049) for t in range(1000)] == [None] * 1000
    s = m.summary(10.0)
    assert s["episodes"] == 0 and s["behind_s"] == 0.0 and not s["behind_at_end"]


def test_an_episode_is_said_when_it_starts_while_it_lasts_and_when_it_ends() -> None:
    m = LagMonitor(threshold_s=0.05, repeat_s=1.0)
    lines = [(t, m.update(t, lag)) for t, lag in
             [(0.0, 0.0), (1.0, 0.2), (1.5, 0.4), (2.1, 0.3), (2.5, 0.04), (3.0, 0.01)]]
    said = [(t, line) for t, line in lines if line]
    assert [t for t, _ in said] == [1.0, 2.1, 3.0]  # started, still behind 1.1 s on, caught up
    assert "200 ms behind" in said[0][1]
    assert "still behind" in said[1][1] and "at most 400 ms" in said[1][1]
    assert "caught up" in said[2][1] and "2.0 s behind" in said[2][1]
    s = m.summary(3.0)
    # under half the threshold ends it: 0.04 s at 2.5 s is still the same episode
    assert s["episodes"] == 1 and s["max_lag_s"] == 0.4
    assert s["behind_s"] == pytest.approx(2.0) and s["longest_s"] == pytest.approx(2.0)


def test_two_episodes_and_one_still_open_at_the_end() -> None:
    m = LagMonitor(threshold_s=0.1)
    for t, lag in [(0, 0.5), (1, 0.0), (2, 0.0), (3, 0.3), (6, 0.3)]:
        m.update(float(t), lag)
    s = m.summary(10.0)
    assert s["episodes"] == 2 and s["behind_at_end"]
    assert s["longest_s"] == 7.0  # the open one, counted to the summary's time
    assert s["behind_s"] == 4.0  # 1 s of the first, 3 s of the second up to its last update


@pytest.mark.parametrize("kwargs", [{"threshold_s": 0.0}, {"repeat_s": -1.0}])
def test_bad_settings_are_refused(kwargs: dict[str, float]) -> None:
    with pytest.raises(ValueError):
        LagMonitor(**kwargs)
