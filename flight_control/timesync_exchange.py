"""The requester's side of the Timesync exchange (``px4_msgs/Timesync``, tc1/ts1).

A request carries ``tc1 = 0`` and ``ts1`` = our clock [ns]; the FCU answers with its own
clock in ``tc1`` and our ``ts1`` echoed. ``/fmu/out/timesync`` is shared by every
requester, so a reply counts only if it answers one of our own outstanding requests
(same ``seq`` and ``ts1``). Every matched reply feeds each estimator given, so several
can run side by side on the same exchanges.
"""

from __future__ import annotations

from typing import Any

import interfaces
from flight_control.timesync import TimesyncEstimate, TimesyncEstimator, ns_to_us

_SEQ_MODULO = 256  # Timesync.seq is a uint8


class TimesyncExchange:
    """Builds requests and matches replies for one requester."""

    def __init__(self, *estimators: TimesyncEstimator) -> None:
        if not estimators:
            raise ValueError("TimesyncExchange needs at least one estimator")
        self.estimators = estimators
        self._seq = 0
        self._outstanding: dict[int, int] = {}  # seq -> ts1 [ns]
        self.unmatched = 0

    def request(self, now_ns: int, fcu_stamp_us: int | None = None) -> Any:
        """A request sent at ``now_ns`` (companion clock); ``fcu_stamp_us`` stamps it on
        the FCU clock when known (the message's ``timestamp``), else our own time."""
        self._seq = (self._seq + 1) % _SEQ_MODULO
        self._outstanding[self._seq] = now_ns
        stamp = ns_to_us(now_ns) if fcu_stamp_us is None else fcu_stamp_us
        return interfaces.new("px4_msgs/msg/Timesync", timestamp=stamp, seq=self._seq, tc1=0,
                              ts1=now_ns)

    def reply(self, msg: Any, now_ns: int) -> tuple[TimesyncEstimate, ...] | None:
        """Feed a reply received at ``now_ns``; None if it is not an answer to us."""
        seq, ts1, tc1 = int(msg.seq), int(msg.ts1), int(msg.tc1)
        if tc1 <= 0 or self._outstanding.get(seq) != ts1:
            self.unmatched += tc1 > 0
            return None
        del self._outstanding[seq]
        now_us = ns_to_us(now_ns)
        return tuple(est.update(ns_to_us(ts1), ns_to_us(tc1), now_us)
                     for est in self.estimators)
