"""PX4's time-sync filter: converting stamps before and after convergence, and a reset.

The filter's gains, gates and convergence are tested against PX4's code in
tests/flight_control/test_timesync.py; these cover what the rest of the stack relies on.
"""

from __future__ import annotations

from interfaces.px4.timesync import (
    CONVERGENCE_WINDOW_SAMPLES,
    MAX_DEVIATION_SAMPLE_US,
    MAX_RTT_SAMPLE_US,
    Px4Timesync,
    RejectReason,
)

OFFSET_US = 30_000_000  # local - remote


def _feed(est: Px4Timesync, n: int, t_us: int, offset_us: int = OFFSET_US,
          rtt_us: int = 2_000) -> int:
    """``n`` symmetric exchanges 5 ms apart from local ``t_us``; returns the next send time."""
    for _ in range(n):
        est.update(t_us, t_us + rtt_us // 2 - offset_us, t_us + rtt_us)
        t_us += 5_000
    return t_us


def test_sync_stamp_is_now_until_converged_then_the_remote_stamp_moved_by_the_offset() -> None:
    est = Px4Timesync()
    t = _feed(est, CONVERGENCE_WINDOW_SAMPLES - 1, 100_000_000)
    assert not est.sync_converged()
    assert est.sync_stamp(5_000_000, now_us=t) == t, "unconverged: the local time of receipt"
    _feed(est, 1, t)
    assert est.sync_converged() and est.estimate.converged
    assert est.sync_stamp(5_000_000, now_us=t) == 5_000_000 + OFFSET_US


def test_reset_forgets_the_filter_but_keeps_the_totals() -> None:
    est = Px4Timesync()
    t = _feed(est, CONVERGENCE_WINDOW_SAMPLES + 10, 100_000_000)
    est.update(t, t - OFFSET_US, t + MAX_RTT_SAMPLE_US)  # too slow
    assert est.estimate.rejected is RejectReason.HIGH_RTT and est.estimate.high_rtt_count == 1
    t += 20_000
    jumped = OFFSET_US + 2 * MAX_DEVIATION_SAMPLE_US
    est.update(t, t + 1_000 - jumped, t + 2_000)  # a clock jump: one deviating sample
    assert est.estimate.rejected is RejectReason.HIGH_DEVIATION
    assert est.estimate.high_deviation_count == 1 and est.estimate.high_rtt_count == 1
    est.reset()
    after = est.estimate
    assert (after.offset_us, after.skew_ppm, after.samples) == (0, 0.0, 0)
    assert not after.converged and after.resets == 1
    assert (after.high_rtt_count, after.high_deviation_count) == (0, 0)
    assert (after.high_rtt_total, after.high_deviation_total) == (1, 1)
    assert est.remote_to_local(1_000) == 1_000 and est.skew_us_per_sample == 0.0
    # the next sample starts the filter again, at the offset it observes
    _feed(est, 1, t + 20_000, offset_us=jumped)
    assert est.estimate.offset_us == jumped and est.estimate.samples == 1
    est.reset()
    assert est.estimate.resets == 2


def test_the_smallest_remote_stamp_and_a_zero_round_trip_are_samples() -> None:
    est = Px4Timesync()
    assert est.update(1_000, 1, 1_002).rejected is RejectReason.NONE  # tc1 = 1 us
    assert est.update(2_000, 1_000, 2_000).rejected is RejectReason.NONE  # rtt = 0
    assert est.estimate.samples == 2


def test_skew_is_reported_from_the_second_sample_per_local_time_between_samples() -> None:
    est = Px4Timesync()
    est.update(1_000_000, 500_000, 1_000_000)
    assert est.estimate.skew_ppm == 0.0, "one sample has no skew"
    est.update(1_000_000 + 1, 500_000 - 9, 1_000_000 + 1)  # the offset grew by 10 us in 1 us
    assert est.skew_us_per_sample != 0.0
    assert est.estimate.skew_ppm == est.skew_us_per_sample / 1 * 1e6  # 1 us per sample
    again = Px4Timesync()
    again.update(1_000_000, 500_000, 1_000_000)
    again.update(1_000_000, 500_010, 1_000_000)  # same local time: no interval, no skew
    assert again.estimate.skew_ppm == 0.0


def test_reset_restores_the_initial_gains() -> None:
    est = Px4Timesync()
    _feed(est, 100, 100_000_000)
    assert est.gains != (0.05, 0.05)
    est.reset()
    assert est.gains == (0.05, 0.05)
