"""The PX4 time-sync contract: the estimator protocol, PX4's filter and the Timesync exchange.

Pure (standard library plus the typed-message API). Both sides of the link import it: the
simulated firmware answers and filters with it, the companion bridge requests with it.

Clock offset estimators:

Every estimator consumes one timesync exchange at a time, named as in MAVLink/PX4 and in
seed 000 (Algorithm 3, Equation (1)):

=========  ==========================  ===========================================
argument   seed 000                    meaning
=========  ==========================  ===========================================
ts1_us     T_Packet Creation (t1)      local clock when the request was sent
tc1_us     T_Remote Stamp (t2)         remote clock when the remote stamped it
now_us     T_Current (t3)              local clock when the reply arrived
=========  ==========================  ===========================================

All times are int microseconds. The offset is ``local - remote`` (PX4's sign), so
``local = remote + offset``. The ``px4_msgs`` ``Timesync`` message carries ``tc1``/``ts1`` in
nanoseconds: convert with :func:`ns_to_us` (PX4's truncating ``ns / 1000``) at the boundary.

Two estimators sit behind the :class:`TimesyncEstimator` protocol and the
:data:`ESTIMATORS` registry (chosen by name with :func:`make_estimator`), both on
:class:`GatedTimesync`, which keeps what they share (the remote-stamp and RTT gates, the
rejection counts, resets and the estimate) and leaves them the filter:

``"px4"``    :class:`Px4Timesync`, seed 000 Algorithm 3 as PX4 ``src/lib/timesync`` codes it.
``"kalman"`` :class:`KalmanTimesync`, an RTT-weighted offset/skew Kalman filter (ours).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass, replace
from enum import Enum
from typing import Any, Protocol, runtime_checkable

import interfaces

TIMESYNC_MSG = "quadmission_interfaces/msg/Timesync"  # the modelled XRCE session sync

__all__ = [
    "ALPHA_GAIN_FINAL",
    "ALPHA_GAIN_INITIAL",
    "BETA_GAIN_FINAL",
    "BETA_GAIN_INITIAL",
    "CONVERGENCE_WINDOW_SAMPLES",
    "MAX_CONSECUTIVE_HIGH_DEVIATION",
    "MAX_CONSECUTIVE_HIGH_RTT",
    "MAX_DEVIATION_SAMPLE_US",
    "MAX_RTT_SAMPLE_US",
    "PPM",
    "US_PER_S",
    "GatedTimesync",
    "Px4Timesync",
    "RejectReason",
    "TimesyncEstimate",
    "TimesyncEstimator",
    "TimesyncExchange",
    "TimesyncSample",
    "ns_to_us",
    "px4_gains",
]

# --- PX4 src/lib/timesync/Timesync.hpp constants (seed 000 Equations (4)-(9)) -----------
ALPHA_GAIN_INITIAL = 0.05  # offset EMA gain at sample 0 (seed: alpha_max), dimensionless
BETA_GAIN_INITIAL = 0.05  # skew EMA gain at sample 0 (seed: beta_max), dimensionless
ALPHA_GAIN_FINAL = 0.003  # offset EMA gain once converged (seed: alpha_min)
BETA_GAIN_FINAL = 0.003  # skew EMA gain once converged (seed: beta_min)
CONVERGENCE_WINDOW_SAMPLES = 500  # accepted samples until converged, Equation (6)
MAX_RTT_SAMPLE_US = 10_000  # samples with RTT >= this are not used, Equation (4)
MAX_DEVIATION_SAMPLE_US = 100_000  # |estimate - observed| gate once converged, Equation (5)
MAX_CONSECUTIVE_HIGH_RTT = 5  # PX4 logs once at this many consecutive high-RTT samples
MAX_CONSECUTIVE_HIGH_DEVIATION = 5  # more than this many in a row resets the filter

US_PER_S = 1_000_000
PPM = 1e6


def ns_to_us(t_ns: int) -> int:
    """Nanoseconds to microseconds as PX4 does it (``ns / 1000ULL``: truncation toward 0)."""
    return _div_trunc(t_ns, 1000)


def _div_trunc(a: int, b: int) -> int:
    """C integer division (truncates toward zero; Python's ``//`` floors)."""
    q = abs(a) // abs(b)
    return q if (a >= 0) == (b > 0) else -q


class RejectReason(Enum):
    """Why the last exchange did not update the filter (``NONE``: it did)."""

    NONE = "none"
    NO_REMOTE_STAMP = "no_remote_stamp"  # tc1 <= 0: not a reply to our request
    HIGH_RTT = "high_rtt"  # round trip >= the RTT gate (or negative)
    HIGH_DEVIATION = "high_deviation"  # observed offset too far from the estimate


@dataclass(frozen=True, slots=True)
class TimesyncSample:
    """One exchange and what it observes (seed Equations (1) and (4))."""

    ts1_us: int  # local send time (t1)
    tc1_us: int  # remote stamp (t2)
    now_us: int  # local receive time (t3)
    observed_offset_us: int  # (ts1 + now - 2 tc1) / 2, truncated toward zero as in C
    rtt_us: int  # now - ts1

    @classmethod
    def from_stamps(cls, ts1_us: int, tc1_us: int, now_us: int) -> TimesyncSample:
        return cls(
            ts1_us=ts1_us,
            tc1_us=tc1_us,
            now_us=now_us,
            observed_offset_us=_div_trunc(ts1_us + now_us - 2 * tc1_us, 2),
            rtt_us=now_us - ts1_us,
        )

    @property
    def mid_us(self) -> int:
        """Local time the observed offset refers to (half-way through the round trip)."""
        return self.ts1_us + (self.now_us - self.ts1_us) // 2


@dataclass(frozen=True, slots=True)
class TimesyncEstimate:
    """What an estimator knows after its last update (``TimesyncStatus`` plus skew and state)."""

    observed_offset_us: int = 0  # raw local - remote of the last exchange
    offset_us: int = 0  # estimated local - remote
    skew_ppm: float = 0.0  # estimated d(offset)/d(local time) [ppm]
    rtt_us: int = 0  # round trip of the last exchange
    converged: bool = False
    resets: int = 0  # filter resets since construction (clock jumps and reset() calls)
    rejected: RejectReason = RejectReason.NONE  # outcome of the last exchange
    samples: int = 0  # samples in the filter since the last reset (PX4 ``_sequence``)
    high_rtt_count: int = 0  # consecutive HIGH_RTT rejections
    high_deviation_count: int = 0  # consecutive HIGH_DEVIATION rejections
    high_rtt_total: int = 0  # HIGH_RTT rejections since construction
    high_deviation_total: int = 0  # HIGH_DEVIATION rejections since construction


@runtime_checkable
class TimesyncEstimator(Protocol):
    """A clock-offset estimator fed one timesync exchange at a time."""

    def update(self, ts1_us: int, tc1_us: int, now_us: int) -> TimesyncEstimate:
        """Consume one exchange (t1, t2, t3) and return the new estimate."""
        ...

    @property
    def estimate(self) -> TimesyncEstimate:
        """The estimate after the last update."""
        ...

    def remote_to_local(self, t_us: int) -> int:
        """A remote (FCU) timestamp on the local clock."""
        ...

    def local_to_remote(self, t_us: int) -> int:
        """A local timestamp on the remote (FCU) clock."""
        ...

    def reset(self) -> None:
        """Forget every sample (counts as a reset)."""
        ...


class GatedTimesync(ABC):
    """What every filtering estimator does around its filter (STYLE 6: the lifecycle here,
    the filter in hooks): a reply without a remote stamp (``tc1 <= 0``) changes nothing
    but the estimate's ``rejected``; a round trip outside ``[0, max_rtt_us)`` is rejected
    as HIGH_RTT and counted; any other exchange goes to :meth:`_accept`, which filters it
    or rejects it as HIGH_DEVIATION (:meth:`_deviated` counts that). The estimate is
    rebuilt after each exchange from the counts and :meth:`_state`. :meth:`reset` clears
    the filter (:meth:`_restart`), then :meth:`_restarted` clears the consecutive counts
    and counts a reset; a filter that restarts itself on a clock jump calls
    :meth:`_restarted` too."""

    def __init__(self, max_rtt_us: int) -> None:
        self._max_rtt_us = max_rtt_us
        self._resets = 0
        self._high_rtt_total = 0
        self._high_deviation_total = 0
        self._high_rtt_count = 0  # consecutive HIGH_RTT rejections
        self._high_deviation_count = 0  # consecutive HIGH_DEVIATION rejections
        self._estimate = TimesyncEstimate()

    @property
    def estimate(self) -> TimesyncEstimate:
        return self._estimate

    def update(self, ts1_us: int, tc1_us: int, now_us: int) -> TimesyncEstimate:
        sample = TimesyncSample.from_stamps(ts1_us, tc1_us, now_us)
        if tc1_us <= 0:  # not a reply to our request (PX4 ignores it, publishing nothing)
            self._estimate = replace(self._estimate, rejected=RejectReason.NO_REMOTE_STAMP)
            return self._estimate
        if 0 <= sample.rtt_us < self._max_rtt_us:
            rejected = self._accept(sample)
        else:
            rejected = RejectReason.HIGH_RTT
            self._high_rtt_total += 1
            self._high_rtt_count += 1
        offset_us, skew_ppm, converged, samples = self._state(sample)
        self._estimate = TimesyncEstimate(
            observed_offset_us=sample.observed_offset_us,
            offset_us=offset_us,
            skew_ppm=skew_ppm,
            rtt_us=sample.rtt_us,
            converged=converged,
            resets=self._resets,
            rejected=rejected,
            samples=samples,
            high_rtt_count=self._high_rtt_count,
            high_deviation_count=self._high_deviation_count,
            high_rtt_total=self._high_rtt_total,
            high_deviation_total=self._high_deviation_total,
        )
        return self._estimate

    def reset(self) -> None:
        self._restart()
        self._restarted()
        self._estimate = replace(
            self._estimate, offset_us=0, skew_ppm=0.0, converged=False, resets=self._resets,
            samples=0, high_rtt_count=0, high_deviation_count=0,
        )

    def _deviated(self) -> int:
        """Count a HIGH_DEVIATION rejection; how many in a row now."""
        self._high_deviation_total += 1
        self._high_deviation_count += 1
        return self._high_deviation_count

    def _restarted(self) -> None:
        """The filter started again from nothing (a reset or a clock jump): the
        consecutive rejections are over, and it counts as a reset."""
        self._high_rtt_count = 0
        self._high_deviation_count = 0
        self._resets += 1

    def _accepted(self) -> None:
        """A sample went into the filter: the consecutive rejections are over."""
        self._high_deviation_count = 0
        self._high_rtt_count = 0

    @abstractmethod
    def _accept(self, sample: TimesyncSample) -> RejectReason:
        """Filter ``sample`` (its RTT passed the gate): NONE, or HIGH_DEVIATION."""

    @abstractmethod
    def _state(self, sample: TimesyncSample) -> tuple[int, float, bool, int]:
        """After ``sample``: (offset [us], skew [ppm], converged, samples in the filter)."""

    @abstractmethod
    def _restart(self) -> None:
        """Forget the filter's samples (the RTT history too, where it keeps one)."""

    @abstractmethod
    def remote_to_local(self, t_us: int) -> int:
        """A remote (FCU) timestamp on the local clock."""

    @abstractmethod
    def local_to_remote(self, t_us: int) -> int:
        """A local timestamp on the remote (FCU) clock."""


def px4_gains(samples: int) -> tuple[float, float]:
    """Gain schedule ``(alpha, beta)`` after ``samples`` accepted samples (Equations (7)-(9)).

    ``p = 1 - exp(0.5 (1 - 1 / (1 - N / 500)))`` rises from 0 at ``N = 0`` to 1 as ``N``
    approaches the convergence window; gains go from the initial to the final values.
    """
    if samples >= CONVERGENCE_WINDOW_SAMPLES:
        return ALPHA_GAIN_FINAL, BETA_GAIN_FINAL
    progress = samples / CONVERGENCE_WINDOW_SAMPLES
    p = 1.0 - math.exp(0.5 * (1.0 - 1.0 / (1.0 - progress)))
    alpha = p * ALPHA_GAIN_FINAL + (1.0 - p) * ALPHA_GAIN_INITIAL
    beta = p * BETA_GAIN_FINAL + (1.0 - p) * BETA_GAIN_INITIAL
    return alpha, beta


class Px4Timesync(GatedTimesync):
    """Seed 000 Algorithm 3, as PX4 ``src/lib/timesync/Timesync.cpp`` implements it.

    A double exponential smoothing (Holt) filter of the observed offset with a gain
    schedule, an RTT gate, and a deviation gate that resets the filter on a time jump.
    Read against PX4-Autopilot ``Timesync.cpp`` @ 15c4f0887da9 (and @ cea185268e13) and
    ``Timesync.hpp`` @ 2363c03bfe82. Where the paper and the code differ this class follows
    the code:

    1. Deviation gate, Equation (5): the paper writes the signed
       ``Offset_Est(i) - Offset_Obs(i+1) < 100 ms``; Algorithm 3 line 13 and the code use
       ``|.|`` and compare against the estimate truncated to int64 (``(int64_t)_time_offset``).
       The gate is strict ``> 100 ms``, applied only once converged (``N >= 500``).
    2. Integer arithmetic: the code computes the observed offset as int64 with C division
       (truncation toward zero) after truncating the ns stamps to us; the paper's
       Equation (1) is real-valued. The reported estimate is the double state truncated
       toward zero. Here the stamps arrive in us already (see :func:`ns_to_us`).
    3. RTT is ``uint64`` in the code: a reply stamped before its request (``now < ts1``)
       wraps to a huge RTT and is rejected as high-RTT. The paper has no such case.
    4. High-RTT counting: the paper only counts (Algorithm 3 line 33; Algorithms 1-2
       ``high_rtt_counter``). The code also keeps the count consecutive: it is cleared by
       every accepted sample and by a reset, and PX4 logs once when it reaches
       ``MAX_CONSECUTIVE_HIGH_RTT`` (5). The older revision @ cea185268e13 instead warned at
       ``> 5`` and then zeroed the count to rate-limit the warning; we follow @ 15c4f0887da9
       (the count keeps rising). Neither variant ever resets the filter on high RTT.
       ``high_rtt_total`` is ours (a cumulative count for diagnostics).
    5. Reset trigger: the sample that pushes ``high_deviation_count`` past 5 (the 6th in a
       row) resets the filter and is itself discarded; the estimate reads 0 until the next
       accepted sample re-initialises it (``N == 0`` branch of ``add_sample``). The paper's
       prose says "5 consecutive samples" (as does a code comment); the test is ``> 5``.
    6. Algorithms 1-2 (the seed's ROS nodes) gate on RTT only, with no deviation gate;
       Algorithm 3 and the code add the deviation gate. We follow the code.
    7. Skew units: the code's skew is the offset change per *accepted sample* [us/sample],
       so skipped (rejected) exchanges and the exchange rate are invisible to it. The
       estimate reports ``skew_ppm`` = that per-sample skew divided by the mean local
       interval between accepted samples since the last reset (ours, for a common unit);
       :attr:`skew_us_per_sample` exposes the code's own state.
    8. Converting stamps: PX4 ``sync_stamp(usec)`` returns ``usec + offset`` once converged
       and otherwise the *current local time* (``hrt_absolute_time()``); a pure module has
       no clock, so :meth:`sync_stamp` takes ``now_us`` from the caller, while
       :meth:`remote_to_local` / :meth:`local_to_remote` always apply the estimate
       (``+/- offset``, no skew, as the code does); check ``estimate.converged`` first.
    9. Argument order: PX4 ``update(now, remote, originate)`` [us, ns, ns];
       ours ``update(ts1_us, tc1_us, now_us)`` [us]. The ``tc1 > 0`` check is kept.
    """

    def __init__(self) -> None:
        super().__init__(MAX_RTT_SAMPLE_US)
        self._restart()

    def _restart(self) -> None:
        # PX4 reset_filter(): all statistics and parameters (the counts: the base's).
        self._sequence = 0
        self._time_offset = 0.0  # [us]
        self._time_skew = 0.0  # [us per accepted sample]
        self._filter_alpha = ALPHA_GAIN_INITIAL
        self._filter_beta = BETA_GAIN_INITIAL
        self._first_accepted_us: int | None = None
        self._last_accepted_us = 0

    # --- protocol --------------------------------------------------------------------
    @property
    def skew_us_per_sample(self) -> float:
        """The code's skew state: offset change per accepted sample [us]."""
        return self._time_skew

    @property
    def gains(self) -> tuple[float, float]:
        """The ``(alpha, beta)`` gains used by the last filter update."""
        return self._filter_alpha, self._filter_beta

    def sync_converged(self) -> bool:
        return self._sequence >= CONVERGENCE_WINDOW_SAMPLES

    def _accept(self, sample: TimesyncSample) -> RejectReason:
        deviation = abs(int(self._time_offset) - sample.observed_offset_us)
        if self.sync_converged() and deviation > MAX_DEVIATION_SAMPLE_US:
            if self._deviated() > MAX_CONSECUTIVE_HIGH_DEVIATION:
                self.reset()
            return RejectReason.HIGH_DEVIATION
        self._filter_alpha, self._filter_beta = px4_gains(self._sequence)
        self._add_sample(sample.observed_offset_us, sample.now_us)
        self._sequence += 1
        self._accepted()
        return RejectReason.NONE

    def _state(self, sample: TimesyncSample) -> tuple[int, float, bool, int]:
        return int(self._time_offset), self._skew_ppm(), self.sync_converged(), self._sequence

    def remote_to_local(self, t_us: int) -> int:
        return t_us + int(self._time_offset)

    def local_to_remote(self, t_us: int) -> int:
        return t_us - int(self._time_offset)

    def sync_stamp(self, t_us: int, now_us: int) -> int:
        """PX4 ``sync_stamp``: remote ``t_us`` on the local clock, or ``now_us`` if unconverged."""
        return self.remote_to_local(t_us) if self.sync_converged() else now_us

    # --- filter ----------------------------------------------------------------------
    def _add_sample(self, offset_us: int, now_us: int) -> None:
        time_offset_prev = self._time_offset
        if self._sequence == 0:
            self._time_offset = float(offset_us)
            self._first_accepted_us = now_us
        else:
            a, b = self._filter_alpha, self._filter_beta
            self._time_offset = a * offset_us + (1.0 - a) * (self._time_offset + self._time_skew)
            self._time_skew = (
                b * (self._time_offset - time_offset_prev) + (1.0 - b) * self._time_skew
            )
        self._last_accepted_us = now_us

    def _skew_ppm(self) -> float:
        if self._first_accepted_us is None or self._sequence < 2:
            return 0.0
        interval_us = (self._last_accepted_us - self._first_accepted_us) / (self._sequence - 1)
        return self._time_skew / interval_us * PPM if interval_us > 0 else 0.0


# --- the exchange (requester side) -----------------------------------------------------
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
        return interfaces.new(TIMESYNC_MSG, timestamp=stamp, seq=self._seq, tc1=0,
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
