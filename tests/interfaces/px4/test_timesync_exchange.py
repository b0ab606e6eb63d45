"""The requester's side of the Timesync exchange: only answers to our requests count."""

from __future__ import annotations

import interfaces
from flight_control.timesync import make_estimator
from interfaces.px4.timesync import TimesyncExchange


def _answer(request: object, fcu_ns: int) -> object:
    return interfaces.new("px4_msgs/msg/Timesync", seq=request.seq,  # type: ignore[attr-defined]
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
    foreign = interfaces.new("px4_msgs/msg/Timesync", seq=request.seq, tc1=7, ts1=123)
    assert exchange.reply(foreign, now_ns=1_003_000_000) is None
    assert exchange.reply(request, now_ns=1_003_000_000) is None
    assert exchange.unmatched == 2
    assert px4.estimate.samples == 1
    # the observed offset is local - remote: companion 1.0005 s vs FCU 5.0005 s
    assert px4.estimate.observed_offset_us == -4_000_000
