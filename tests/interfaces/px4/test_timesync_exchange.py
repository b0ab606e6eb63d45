"""The requester's side of the Timesync exchange: only answers to our requests count."""

from __future__ import annotations

import pytest

import interfaces
from flight_control.timesync import make_estimator
from interfaces.px4.timesync import Px4Timesync, TimesyncExchange

TIMESYNC_MSG = "quadmission_interfaces/msg/Timesync"  # the modelled XRCE session sync


def _answer(request: object, fcu_ns: int) -> object:
    return interfaces.new(TIMESYNC_MSG, seq=request.seq,  # type: ignore[attr-defined]
                          tc1=fcu_ns, ts1=request.ts1)  # type: ignore[attr-defined]


def test_matched_replies_feed_every_estimator_and_others_are_ignored() -> None:
    px4, kalman = make_estimator("px4"), make_estimator("kalman")
    exchange = TimesyncExchange(px4, kalman)
    request = exchange.request(now_ns=1_000_000_000)
    assert request.tc1 == 0 and request.ts1 == 1_000_000_000
    assert exchange.reply(_answer(request, 5_000_500_000), now_ns=1_001_000_000) is not None
    assert px4.estimate.samples == 1 and kalman.estimate.samples == 1
    # the same reply again, someone else's, and a request echoed back: all ignored
    assert exchange.reply(_answer(request, 5_000_500_000), now_ns=1_002_000_000) is None
    foreign = interfaces.new(TIMESYNC_MSG, seq=request.seq, tc1=7, ts1=123)
    assert exchange.reply(foreign, now_ns=1_003_000_000) is None
    assert exchange.reply(request, now_ns=1_003_000_000) is None
    assert exchange.unmatched == 2
    assert px4.estimate.samples == 1
    # the observed offset is local - remote: companion 1.0005 s vs FCU 5.0005 s
    assert px4.estimate.observed_offset_us == -4_000_000


def test_an_exchange_needs_an_estimator() -> None:
    with pytest.raises(ValueError, match=r"^TimesyncExchange needs at least one estimator$"):
        TimesyncExchange()


def test_requests_count_from_1_and_wrap_like_the_uint8_seq() -> None:
    exchange = TimesyncExchange(Px4Timesync())
    seqs = [exchange.request(now_ns=k * 100_000_000).seq for k in range(1, 260)]
    assert seqs[:3] == [1, 2, 3]
    assert seqs[254:258] == [255, 0, 1, 2]
    assert exchange.unmatched == 0


def test_a_request_is_stamped_on_the_fcu_clock_when_known_else_on_ours() -> None:
    exchange = TimesyncExchange(Px4Timesync())
    own = exchange.request(now_ns=2_000_000_999)
    assert (own.timestamp, own.tc1, own.ts1) == (2_000_000, 0, 2_000_000_999)
    fcu = exchange.request(now_ns=3_000_000_000, fcu_stamp_us=77_000_123)
    assert fcu.timestamp == 77_000_123 and fcu.ts1 == 3_000_000_000


def test_each_outstanding_request_is_matched_once_in_any_order() -> None:
    px4 = Px4Timesync()
    exchange = TimesyncExchange(px4)
    first = exchange.request(now_ns=1_000_000_000)
    second = exchange.request(now_ns=1_100_000_000)
    got = exchange.reply(_answer(second, 9_000_000_000), now_ns=1_102_000_000)
    assert got is not None and len(got) == 1
    assert got[0].rtt_us == 2_000
    late = exchange.reply(_answer(first, 9_000_000_000), now_ns=1_104_000_000)
    assert late is not None and late[0].rtt_us == 104_000  # too slow, but it is ours
    assert exchange.unmatched == 0
    assert exchange.reply(_answer(first, 9_000_000_000), now_ns=1_105_000_000) is None
    assert exchange.unmatched == 1


def test_an_unanswered_echo_is_not_counted_but_the_smallest_remote_stamp_is() -> None:
    exchange = TimesyncExchange(Px4Timesync())
    request = exchange.request(now_ns=1_000_000_000)
    stale = interfaces.new(TIMESYNC_MSG, seq=request.seq, tc1=1, ts1=5)
    assert exchange.reply(stale, now_ns=1_001_000_000) is None
    assert exchange.unmatched == 1  # tc1 = 1 ns is an answer, to someone else
    assert exchange.reply(request, now_ns=1_001_000_000) is None
    assert exchange.unmatched == 1  # tc1 = 0: our own request echoed, not an answer
    answer = interfaces.new(TIMESYNC_MSG, seq=request.seq, tc1=1, ts1=request.ts1)
    assert exchange.reply(answer, now_ns=1_001_000_000) is not None, "FCU time 1 ns is a time"
