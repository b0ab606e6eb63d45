"""Companion <-> flight-controller clock offset estimators (pure: standard library only).

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
:data:`ESTIMATORS` registry (chosen by name with :func:`make_estimator`):

``"px4"``    :class:`Px4Timesync`, seed 000 Algorithm 3 as PX4 ``src/lib/timesync`` codes it.
``"kalman"`` :class:`KalmanTimesync`, an RTT-weighted offset/skew Kalman filter (ours).
"""

from __future__ import annotations

import bisect
import math
from collections import deque
from collections.abc import Callable, Mapping
from dataclasses import dataclass, fields, replace
from enum import Enum
from types import MappingProxyType
from typing import Protocol, runtime_checkable

from flight_control.errors import TimesyncParameterError, UnknownEstimatorError

__all__ = [
    "ALPHA_GAIN_FINAL",
    "ALPHA_GAIN_INITIAL",
    "BETA_GAIN_FINAL",
    "BETA_GAIN_INITIAL",
    "CONVERGENCE_WINDOW_SAMPLES",
    "ESTIMATORS",
    "MAX_CONSECUTIVE_HIGH_DEVIATION",
    "MAX_CONSECUTIVE_HIGH_RTT",
    "MAX_DEVIATION_SAMPLE_US",
    "MAX_RTT_SAMPLE_US",
    "KalmanParams",
    "KalmanTimesync",
    "Px4Timesync",
    "RejectReason",
    "TimesyncEstimate",
    "TimesyncEstimator",
    "TimesyncSample",
    "make_estimator",
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

_US_PER_S = 1_000_000
_PPM = 1e6


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


class Px4Timesync:
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
        self._resets = 0
        self._high_rtt_total = 0
        self._high_deviation_total = 0
        self._clear()
        self._estimate = TimesyncEstimate()

    def _clear(self) -> None:
        # PX4 reset_filter(): all statistics and parameters.
        self._sequence = 0
        self._time_offset = 0.0  # [us]
        self._time_skew = 0.0  # [us per accepted sample]
        self._filter_alpha = ALPHA_GAIN_INITIAL
        self._filter_beta = BETA_GAIN_INITIAL
        self._high_deviation_count = 0
        self._high_rtt_count = 0
        self._first_accepted_us: int | None = None
        self._last_accepted_us = 0

    # --- protocol --------------------------------------------------------------------
    @property
    def estimate(self) -> TimesyncEstimate:
        return self._estimate

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

    def update(self, ts1_us: int, tc1_us: int, now_us: int) -> TimesyncEstimate:
        sample = TimesyncSample.from_stamps(ts1_us, tc1_us, now_us)
        if tc1_us <= 0:
            # PX4 ignores the message (and publishes nothing).
            self._estimate = replace(self._estimate, rejected=RejectReason.NO_REMOTE_STAMP)
            return self._estimate
        rejected = RejectReason.NONE
        deviation = abs(int(self._time_offset) - sample.observed_offset_us)
        if 0 <= sample.rtt_us < MAX_RTT_SAMPLE_US:
            if self.sync_converged() and deviation > MAX_DEVIATION_SAMPLE_US:
                rejected = RejectReason.HIGH_DEVIATION
                self._high_deviation_total += 1
                self._high_deviation_count += 1
                if self._high_deviation_count > MAX_CONSECUTIVE_HIGH_DEVIATION:
                    self.reset()
            else:
                self._filter_alpha, self._filter_beta = px4_gains(self._sequence)
                self._add_sample(sample.observed_offset_us, now_us)
                self._sequence += 1
                self._high_deviation_count = 0
                self._high_rtt_count = 0
        else:
            rejected = RejectReason.HIGH_RTT
            self._high_rtt_total += 1
            self._high_rtt_count += 1
        self._estimate = self._make_estimate(sample, rejected)
        return self._estimate

    def remote_to_local(self, t_us: int) -> int:
        return t_us + int(self._time_offset)

    def local_to_remote(self, t_us: int) -> int:
        return t_us - int(self._time_offset)

    def sync_stamp(self, t_us: int, now_us: int) -> int:
        """PX4 ``sync_stamp``: remote ``t_us`` on the local clock, or ``now_us`` if unconverged."""
        return self.remote_to_local(t_us) if self.sync_converged() else now_us

    def reset(self) -> None:
        self._clear()
        self._resets += 1
        self._estimate = replace(
            self._estimate, offset_us=0, skew_ppm=0.0, converged=False, resets=self._resets,
            samples=0, high_rtt_count=0, high_deviation_count=0,
        )

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
        return self._time_skew / interval_us * _PPM if interval_us > 0 else 0.0

    def _make_estimate(self, sample: TimesyncSample, rejected: RejectReason) -> TimesyncEstimate:
        return TimesyncEstimate(
            observed_offset_us=sample.observed_offset_us,
            offset_us=int(self._time_offset),
            skew_ppm=self._skew_ppm(),
            rtt_us=sample.rtt_us,
            converged=self.sync_converged(),
            resets=self._resets,
            rejected=rejected,
            samples=self._sequence,
            high_rtt_count=self._high_rtt_count,
            high_deviation_count=self._high_deviation_count,
            high_rtt_total=self._high_rtt_total,
            high_deviation_total=self._high_deviation_total,
        )


# --- ours: RTT-weighted Kalman filter ---------------------------------------------------
@dataclass(frozen=True, slots=True)
class KalmanParams:
    """Parameters of :class:`KalmanTimesync` (units beside each; ranges in ``_KALMAN_RANGES``)."""

    max_rtt_us: int = MAX_RTT_SAMPLE_US  # hard RTT gate [us]
    rtt_window_samples: int = 2000  # recent RTTs kept for the floor quantile
    rtt_floor_quantile: float = 0.05  # RTT quantile taken as the floor
    floor_noise_us: float = 80.0  # offset noise of a sample at the RTT floor [us, 1-sigma]
    offset_walk_us_per_sqrt_s: float = 1.0  # offset random walk [us/sqrt(s)]
    skew_walk_ppm_per_sqrt_s: float = 0.1  # skew random walk [ppm/sqrt(s)]
    skew_prior_ppm: float = 200.0  # prior on the skew after a reset [ppm, 1-sigma]
    gate_sigmas: float = 6.0  # innovation gate [standard deviations]
    gate_floor_us: int = 1_000  # innovations below this are never gated [us]
    max_consecutive_high_deviation: int = MAX_CONSECUTIVE_HIGH_DEVIATION  # more: clock jump
    converged_std_us: float = 20.0  # converged once the offset 1-sigma is below this [us]
    converged_min_samples: int = 10  # ... and at least this many samples are in

    def __post_init__(self) -> None:
        for key, lo, hi, lo_open in _KALMAN_RANGES:
            value = getattr(self, key)
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise TimesyncParameterError(f"{key}={value!r}: must be a number")
            if not ((lo < value) if lo_open else (lo <= value)) or value > hi:
                left = "(" if lo_open else "["
                raise TimesyncParameterError(f"{key}={value!r}: must be in {left}{lo}, {hi}]")
        for key in ("max_rtt_us", "rtt_window_samples", "gate_floor_us",
                    "max_consecutive_high_deviation", "converged_min_samples"):
            if not isinstance(getattr(self, key), int):
                raise TimesyncParameterError(f"{key}={getattr(self, key)!r}: must be an int")


# Allowed range of each KalmanParams field: (key, low, high, low bound open); high is closed.
_KALMAN_RANGES: tuple[tuple[str, float, float, bool], ...] = (
    ("max_rtt_us", 0, 1_000_000, True),
    ("rtt_window_samples", 10, 100_000, False),
    ("rtt_floor_quantile", 0.0, 0.5, False),
    ("floor_noise_us", 0.0, 1e5, True),
    ("offset_walk_us_per_sqrt_s", 0.0, 1e4, False),
    ("skew_walk_ppm_per_sqrt_s", 0.0, 1e3, False),
    ("skew_prior_ppm", 0.0, 1e4, True),
    ("gate_sigmas", 2.0, 100.0, False),
    ("gate_floor_us", 0, 100_000_000, False),
    ("max_consecutive_high_deviation", 1, 1000, False),
    ("converged_std_us", 0.0, 1e6, True),
    ("converged_min_samples", 1, 100_000, False),
)


class KalmanTimesync:
    """Offset and skew as a two-state Kalman filter whose trust in a sample follows its RTT.

    State: offset ``x0`` [us] at local time ``t_ref`` and skew ``x1`` [us/us]; the model is
    a clock with a random-walk offset and a random-walk skew (the standard two-state clock
    model), so the filter starts optimal from the first sample (no gain schedule) and
    keeps a long, lag-free memory in steady state.

    The observed offset of an exchange is off by half the difference of its two one-way
    latencies, so a sample whose RTT is close to the smallest RTTs seen is accurate and a
    slow one can be off by up to half its excess RTT. The measurement variance is therefore
    ``floor_noise_us**2 + (excess / 2)**2`` with ``excess = rtt - floor``, where ``floor``
    is a low quantile of the recent RTTs: a soft minimum-RTT filter (as NTP's clock filter)
    that keeps every sample. Load spikes that pass the hard RTT gate carry a huge variance
    and barely move the estimate.

    Gates (same outcomes as PX4): RTT ``>= max_rtt_us`` is rejected (``HIGH_RTT``); once
    converged, an innovation beyond ``max(gate_floor_us, gate_sigmas * sqrt(S))`` is
    rejected (``HIGH_DEVIATION``), and more than ``max_consecutive_high_deviation`` of them
    in a row is a clock jump: the filter restarts from those rejected samples (after a jump
    they all sit on the new clock, so none is lost and the estimate is right at once). The RTT floor
    survives a jump (RTT uses the local clock only); :meth:`reset` clears everything.

    Limits: the path asymmetry (mean of one-way latency difference at the RTT floor) is not
    observable by any two-way exchange and stays in the estimate; offset steps smaller
    than the gate (1 ms by default) are absorbed at the filter's steady-state rate.
    """

    def __init__(self, params: KalmanParams | None = None) -> None:
        self.params = params if params is not None else KalmanParams()
        p = self.params
        self._r_floor = p.floor_noise_us**2
        self._q_offset = p.offset_walk_us_per_sqrt_s**2 / _US_PER_S  # [us^2 per us]
        self._q_skew = (p.skew_walk_ppm_per_sqrt_s / _PPM) ** 2 / _US_PER_S  # [1 per us]
        self._p_skew0 = (p.skew_prior_ppm / _PPM) ** 2
        self._resets = 0
        self._high_rtt_total = 0
        self._high_deviation_total = 0
        self._rtt_fifo: deque[int] = deque()
        self._rtt_sorted: list[int] = []
        self._clear_filter()
        self._high_rtt_count = 0
        self._estimate = TimesyncEstimate()

    def _clear_filter(self) -> None:
        self._n = 0
        self._t_ref = 0  # local time of the state [us]
        self._x0 = 0.0  # offset at t_ref [us]
        self._x1 = 0.0  # skew [us/us]
        self._p00 = 0.0
        self._p01 = 0.0
        self._p11 = 0.0
        self._pending: list[TimesyncSample] = []
        self._high_deviation_count = 0

    # --- protocol --------------------------------------------------------------------
    @property
    def estimate(self) -> TimesyncEstimate:
        return self._estimate

    @property
    def offset_std_us(self) -> float:
        """The filter's own 1-sigma of the offset at its reference time [us]."""
        return math.sqrt(self._p00)

    def update(self, ts1_us: int, tc1_us: int, now_us: int) -> TimesyncEstimate:
        sample = TimesyncSample.from_stamps(ts1_us, tc1_us, now_us)
        if tc1_us <= 0:
            self._estimate = replace(self._estimate, rejected=RejectReason.NO_REMOTE_STAMP)
            return self._estimate
        if not 0 <= sample.rtt_us < self.params.max_rtt_us:
            self._high_rtt_total += 1
            self._high_rtt_count += 1
            rejected = RejectReason.HIGH_RTT
        else:
            rejected = self._filter(sample, self._rtt_excess(sample.rtt_us))
        self._estimate = self._make_estimate(sample, rejected)
        return self._estimate

    def remote_to_local(self, t_us: int) -> int:
        # local = remote + x0 + x1 (local - t_ref), solved for local.
        return self._t_ref + round((t_us - self._t_ref + self._x0) / (1.0 - self._x1))

    def local_to_remote(self, t_us: int) -> int:
        return t_us - round(self._offset_at(t_us))

    def reset(self) -> None:
        self._rtt_fifo.clear()
        self._rtt_sorted.clear()
        self._clear_filter()
        self._high_rtt_count = 0
        self._resets += 1
        self._estimate = replace(
            self._estimate, offset_us=0, skew_ppm=0.0, converged=False, resets=self._resets,
            samples=0, high_rtt_count=0, high_deviation_count=0,
        )

    # --- filter ----------------------------------------------------------------------
    def _rtt_excess(self, rtt_us: int) -> int:
        """Record ``rtt_us`` and return how far it is above the windowed RTT floor."""
        self._rtt_fifo.append(rtt_us)
        bisect.insort(self._rtt_sorted, rtt_us)
        if len(self._rtt_fifo) > self.params.rtt_window_samples:
            old = self._rtt_fifo.popleft()
            del self._rtt_sorted[bisect.bisect_left(self._rtt_sorted, old)]
        return self._excess_of(rtt_us)

    def _filter(self, sample: TimesyncSample, excess_us: int) -> RejectReason:
        r = self._r_floor + (excess_us / 2.0) ** 2
        z = float(sample.observed_offset_us)
        t = sample.mid_us
        if self._n == 0:
            self._start(z, t, r)
            return RejectReason.NONE
        # Predict to t (constant-skew clock, integrated random-walk process noise).
        dt = float(t - self._t_ref)
        x0 = self._x0 + self._x1 * dt
        p00 = self._p00 + 2.0 * dt * self._p01 + dt * dt * self._p11
        p01 = self._p01 + dt * self._p11
        p11 = self._p11
        if dt > 0.0:
            p00 += self._q_offset * dt + self._q_skew * dt**3 / 3.0
            p01 += self._q_skew * dt**2 / 2.0
            p11 += self._q_skew * dt
        innovation = z - x0
        s = p00 + r
        if self._converged() and abs(innovation) > max(
            float(self.params.gate_floor_us), self.params.gate_sigmas * math.sqrt(s)
        ):
            return self._reject_deviation(sample)
        k0, k1 = p00 / s, p01 / s
        self._x0 = x0 + k0 * innovation
        self._x1 = self._x1 + k1 * innovation
        self._p00 = (1.0 - k0) * p00
        self._p01 = (1.0 - k0) * p01
        self._p11 = p11 - k1 * p01
        self._t_ref = t
        self._n += 1
        self._pending.clear()
        self._high_deviation_count = 0
        self._high_rtt_count = 0
        return RejectReason.NONE

    def _start(self, z: float, t: int, r: float) -> None:
        self._x0, self._x1 = z, 0.0
        self._p00, self._p01, self._p11 = r, 0.0, self._p_skew0
        self._t_ref = t
        self._n = 1
        self._high_deviation_count = 0
        self._high_rtt_count = 0

    def _reject_deviation(self, sample: TimesyncSample) -> RejectReason:
        self._high_deviation_total += 1
        self._high_deviation_count += 1
        self._pending.append(sample)
        if self._high_deviation_count > self.params.max_consecutive_high_deviation:
            # Clock jump: restart from the rejected run, which agrees with the new clock.
            pending = self._pending
            self._clear_filter()
            self._resets += 1
            for s in pending:
                self._filter(s, self._excess_of(s.rtt_us))
        return RejectReason.HIGH_DEVIATION

    def _excess_of(self, rtt_us: int) -> int:
        """How far ``rtt_us`` is above the current RTT floor (0 at or below it)."""
        k = int(self.params.rtt_floor_quantile * (len(self._rtt_sorted) - 1))
        return max(0, rtt_us - self._rtt_sorted[k])

    def _converged(self) -> bool:
        return (self._n >= self.params.converged_min_samples
                and self._p00 <= self.params.converged_std_us**2)

    def _offset_at(self, t_us: int) -> float:
        return self._x0 + self._x1 * (t_us - self._t_ref)

    def _make_estimate(self, sample: TimesyncSample, rejected: RejectReason) -> TimesyncEstimate:
        return TimesyncEstimate(
            observed_offset_us=sample.observed_offset_us,
            offset_us=round(self._offset_at(sample.now_us)) if self._n else 0,
            skew_ppm=self._x1 * _PPM,
            rtt_us=sample.rtt_us,
            converged=self._converged(),
            resets=self._resets,
            rejected=rejected,
            samples=self._n,
            high_rtt_count=self._high_rtt_count,
            high_deviation_count=self._high_deviation_count,
            high_rtt_total=self._high_rtt_total,
            high_deviation_total=self._high_deviation_total,
        )


# --- registry ---------------------------------------------------------------------------
def _make_px4(**params: object) -> Px4Timesync:
    if params:
        raise TimesyncParameterError(
            f"px4 estimator takes no parameters (its constants are PX4's), got {sorted(params)}"
        )
    return Px4Timesync()


def _make_kalman(**params: object) -> KalmanTimesync:
    allowed = {f.name for f in fields(KalmanParams)}
    unknown = sorted(set(params) - allowed)
    if unknown:
        raise TimesyncParameterError(
            f"unknown kalman parameter(s) {unknown}; allowed: {sorted(allowed)}"
        )
    return KalmanTimesync(KalmanParams(**params))  # type: ignore[arg-type]


ESTIMATORS: Mapping[str, Callable[..., TimesyncEstimator]] = MappingProxyType(
    {"px4": _make_px4, "kalman": _make_kalman}
)


def make_estimator(name: str, **params: object) -> TimesyncEstimator:
    """Build the estimator registered as ``name`` (see :data:`ESTIMATORS`) with ``params``."""
    try:
        factory = ESTIMATORS[name]
    except KeyError:
        raise UnknownEstimatorError(
            f"unknown timesync estimator {name!r}; choose one of {sorted(ESTIMATORS)}"
        ) from None
    return factory(**params)
