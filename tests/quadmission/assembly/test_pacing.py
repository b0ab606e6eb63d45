"""quadmission/assembly/pacing.py: simulated time held to rtf times host time, by sleeping only."""

from __future__ import annotations

import pytest

from quadmission.assembly.pacing import RealTimePacer


class _Host:
    def __init__(self, t: float) -> None:
        self.t = t
        self.slept: list[float] = []

    def sleep(self, seconds: float) -> None:
        self.slept.append(seconds)
        self.t += seconds


def test_a_fast_simulation_waits_for_the_host_at_the_rate_asked() -> None:
    host = _Host(100.0)
    pacer = RealTimePacer(2.0, sleep=host.sleep, host_clock=lambda: host.t)
    pacer.update(0, None)  # type: ignore[arg-type]  # the first update is the origin
    pacer.update(1_000_000_000, None)  # type: ignore[arg-type]  # 1 s simulated at rtf 2
    assert host.slept == [pytest.approx(0.5)]
    host.t += 2.0  # the host fell behind: no sleep, no catching up by waiting
    pacer.update(2_000_000_000, None)  # type: ignore[arg-type]
    assert len(host.slept) == 1


def test_with_an_origin_the_start_up_time_is_made_up_first() -> None:
    host = _Host(10.0)  # the command started at 7 s: 3 s of start-up already gone
    pacer = RealTimePacer(1.0, sleep=host.sleep, host_clock=lambda: host.t, origin_host_s=7.0)
    pacer.update(0, None)  # type: ignore[arg-type]
    pacer.update(2_000_000_000, None)  # type: ignore[arg-type]  # still behind: runs free
    assert host.slept == []
    pacer.update(4_000_000_000, None)  # type: ignore[arg-type]  # 4 s simulated, 3 s host
    assert host.slept == [pytest.approx(1.0)]


def test_rtf_must_be_positive() -> None:
    with pytest.raises(ValueError, match="rtf must be > 0"):
        RealTimePacer(0.0)
