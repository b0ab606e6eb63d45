"""Companion-side clock offset estimators: our RTT-weighted Kalman filter and the registry.

The estimator protocol, the shared sample/estimate types, the gates and counts every filter
shares (:class:`~interfaces.px4.timesync.GatedTimesync`) and PX4's own filter are the PX4
contract (:mod:`interfaces.px4.timesync`), imported by the firmware too. Two estimators sit
behind :data:`ESTIMATORS`, chosen by name with :func:`make_estimator`:

``"px4"``    :class:`~interfaces.px4.timesync.Px4Timesync`, seed 000 Algorithm 3 as PX4 codes it.
``"kalman"`` :class:`KalmanTimesync`, an RTT-weighted offset/skew Kalman filter (ours).
"""

from __future__ import annotations

import bisect
import math
from collections import deque
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from types import MappingProxyType

from flight_control.errors import TimesyncParameterError, UnknownEstimatorError
from interfaces.px4.timesync import (
    MAX_CONSECUTIVE_HIGH_DEVIATION,
    MAX_DEVIATION_SAMPLE_US,
    MAX_RTT_SAMPLE_US,
    PPM,
    US_PER_S,
    GatedTimesync,
    Px4Timesync,
    RejectReason,
    TimesyncEstimate,
    TimesyncEstimator,
    TimesyncSample,
)
from runtime.errors import ParameterError
from runtime.parameters import build_parameters, param, validate_parameters

__all__ = ["ESTIMATORS", "KalmanParams", "KalmanTimesync", "ReportedOffset", "make_estimator"]


# --- ours: RTT-weighted Kalman filter ---------------------------------------------------
@dataclass(frozen=True, slots=True)
class KalmanParams:
    """Parameters of :class:`KalmanTimesync`, with their units and allowed ranges."""

    max_rtt_us: int = param(MAX_RTT_SAMPLE_US, unit="us", range=(0, 1_000_000), lo_open=True)
    """Hard RTT gate."""
    rtt_window_samples: int = param(2000, range=(10, 100_000))
    """Recent RTTs kept for the floor quantile."""
    rtt_floor_quantile: float = param(0.05, range=(0.0, 0.5))
    """RTT quantile taken as the floor."""
    floor_noise_us: float = param(80.0, unit="us", range=(0.0, 1e5), lo_open=True)
    """Offset noise (1-sigma) of a sample at the RTT floor."""
    offset_walk_us_per_sqrt_s: float = param(1.0, unit="us/sqrt(s)", range=(0.0, 1e4))
    """Offset random walk."""
    skew_walk_ppm_per_sqrt_s: float = param(0.1, unit="ppm/sqrt(s)", range=(0.0, 1e3))
    """Skew random walk."""
    skew_prior_ppm: float = param(200.0, unit="ppm", range=(0.0, 1e4), lo_open=True)
    """Prior (1-sigma) on the skew after a reset."""
    gate_sigmas: float = param(6.0, range=(2.0, 100.0))
    """Innovation gate [standard deviations]."""
    gate_floor_us: int = param(1_000, unit="us", range=(0, 100_000_000))
    """Innovations below this are never gated."""
    max_consecutive_high_deviation: int = param(MAX_CONSECUTIVE_HIGH_DEVIATION, range=(1, 1000))
    """More gated samples in a row than this: a clock jump, reset."""
    converged_std_us: float = param(20.0, unit="us", range=(0.0, 1e6), lo_open=True)
    """Converged once the offset 1-sigma is below this ..."""
    converged_min_samples: int = param(10, range=(1, 100_000))
    """... and at least this many samples are in; it stays converged until a reset."""

    def __post_init__(self) -> None:
        try:
            validate_parameters(self)
        except ParameterError as exc:
            raise TimesyncParameterError(exc.problem, key=f"kalman.{exc.key}") from None


class KalmanTimesync(GatedTimesync):
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

    Converged, as PX4's ``sync_converged()``, is a latch: set once ``converged_min_samples``
    are in with the offset 1-sigma at most ``converged_std_us``, cleared only by a restart
    (a clock jump or :meth:`reset`). The 1-sigma itself rises between accepted samples
    and falls with each; on a starved host it can cross 20 us every few tenths of a second
    (an exchange with milliseconds of excess RTT after a run of gated ones), and a flag that
    followed it would make the bridge drop the visual odometry for those spells, long
    enough for the FCU to lose its position (``tests/quadmission/scenarios/square/test_launch.py``).

    Limits: the path asymmetry (mean of one-way latency difference at the RTT floor) is not
    observable by any two-way exchange and stays in the estimate; offset steps smaller
    than the gate (1 ms by default) are absorbed at the filter's steady-state rate.
    """

    def __init__(self, params: KalmanParams | None = None) -> None:
        self.params = params if params is not None else KalmanParams()
        p = self.params
        super().__init__(p.max_rtt_us)
        self._r_floor = p.floor_noise_us**2
        self._q_offset = p.offset_walk_us_per_sqrt_s**2 / US_PER_S  # [us^2 per us]
        self._q_skew = (p.skew_walk_ppm_per_sqrt_s / PPM) ** 2 / US_PER_S  # [1 per us]
        self._p_skew0 = (p.skew_prior_ppm / PPM) ** 2
        self._rtt_fifo: deque[int] = deque()
        self._rtt_sorted: list[int] = []
        self._clear_filter()

    def _clear_filter(self) -> None:
        self._n = 0
        self._t_ref = 0  # local time of the state [us]
        self._x0 = 0.0  # offset at t_ref [us]
        self._x1 = 0.0  # skew [us/us]
        self._p00 = 0.0
        self._p01 = 0.0
        self._p11 = 0.0
        self._pending: list[TimesyncSample] = []
        self._has_converged = False

    # --- protocol --------------------------------------------------------------------
    @property
    def offset_std_us(self) -> float:
        """The filter's own 1-sigma of the offset at its reference time [us]."""
        return math.sqrt(self._p00)

    def _accept(self, sample: TimesyncSample) -> RejectReason:
        return self._filter(sample, self._rtt_excess(sample.rtt_us))

    def _state(self, sample: TimesyncSample) -> tuple[int, float, bool, int]:
        offset_us = round(self._offset_at(sample.now_us)) if self._n else 0
        return offset_us, self._x1 * PPM, self._converged(), self._n

    def remote_to_local(self, t_us: int) -> int:
        # local = remote + x0 + x1 (local - t_ref), solved for local.
        return self._t_ref + round((t_us - self._t_ref + self._x0) / (1.0 - self._x1))

    def local_to_remote(self, t_us: int) -> int:
        return t_us - round(self._offset_at(t_us))

    def _restart(self) -> None:
        self._rtt_fifo.clear()
        self._rtt_sorted.clear()
        self._clear_filter()

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
        self._accepted()
        return RejectReason.NONE

    def _start(self, z: float, t: int, r: float) -> None:
        self._x0, self._x1 = z, 0.0
        self._p00, self._p01, self._p11 = r, 0.0, self._p_skew0
        self._t_ref = t
        self._n = 1
        self._accepted()

    def _reject_deviation(self, sample: TimesyncSample) -> RejectReason:
        self._pending.append(sample)
        if self._deviated() > self.params.max_consecutive_high_deviation:
            # Clock jump: restart from the rejected run, which agrees with the new clock.
            pending = self._pending
            self._clear_filter()
            self._restarted()
            for s in pending:
                self._filter(s, self._excess_of(s.rtt_us))
        return RejectReason.HIGH_DEVIATION

    def _excess_of(self, rtt_us: int) -> int:
        """How far ``rtt_us`` is above the current RTT floor (0 at or below it)."""
        k = int(self.params.rtt_floor_quantile * (len(self._rtt_sorted) - 1))
        return max(0, rtt_us - self._rtt_sorted[k])

    def _converged(self) -> bool:
        if not self._has_converged:
            self._has_converged = (self._n >= self.params.converged_min_samples
                                   and self._p00 <= self.params.converged_std_us**2)
        return self._has_converged

    def _offset_at(self, t_us: int) -> float:
        return self._x0 + self._x1 * (t_us - self._t_ref)


# --- registry ---------------------------------------------------------------------------
def _make_px4(**params: object) -> Px4Timesync:
    if params:
        raise TimesyncParameterError(
            f"px4 estimator takes no parameters (its constants are PX4's), got {sorted(params)}"
        )
    return Px4Timesync()


def _make_kalman(**params: object) -> KalmanTimesync:
    try:
        return KalmanTimesync(build_parameters(KalmanParams, params, "kalman"))
    except ParameterError as exc:
        raise TimesyncParameterError(exc.problem, key=exc.key) from None


class ReportedOffset:
    """The offset the FCU itself reports (``TimesyncStatus.estimated_offset``), no filter.

    PX4 v1.17's uXRCE-DDS client syncs inside its session and publishes its estimate
    (FCU clock minus agent clock [us]) on ``/fmu/out/timesync_status``: this is what a
    companion of a real PX4 can read. Our sign is the other way round (local = companion),
    so ``offset_us = -estimated_offset``. Converged once a report with a measured round
    trip arrives. A converged offset that steps by more than PX4's deviation gate
    (``MAX_DEVIATION_SAMPLE_US``) is a new clock (the FCU rebooted, or its clock jumped):
    the estimate restarts from the new report (``resets`` counts it), not converged, and
    converges again at the next. :meth:`update` takes one exchange's observed offset as is.
    """

    def __init__(self) -> None:
        self._estimate = TimesyncEstimate()

    @property
    def estimate(self) -> TimesyncEstimate:
        return self._estimate

    def report(self, estimated_offset_us: int, observed_offset_us: int,
               round_trip_us: int) -> TimesyncEstimate:
        """Take one ``TimesyncStatus`` (its offsets are FCU minus companion)."""
        last = self._estimate
        if last.converged and abs(-int(estimated_offset_us) - last.offset_us) \
                > MAX_DEVIATION_SAMPLE_US:  # a new clock: restart from this report
            self._estimate = TimesyncEstimate(
                offset_us=-int(estimated_offset_us), observed_offset_us=-int(observed_offset_us),
                rtt_us=int(round_trip_us), resets=last.resets + 1, samples=1)
            return self._estimate
        self._estimate = replace(
            self._estimate, offset_us=-int(estimated_offset_us),
            observed_offset_us=-int(observed_offset_us), rtt_us=int(round_trip_us),
            converged=self._estimate.converged or round_trip_us > 0,
            samples=self._estimate.samples + 1)
        return self._estimate

    def update(self, ts1_us: int, tc1_us: int, now_us: int) -> TimesyncEstimate:
        sample = TimesyncSample.from_stamps(ts1_us, tc1_us, now_us)
        self._estimate = replace(
            self._estimate, offset_us=sample.observed_offset_us,
            observed_offset_us=sample.observed_offset_us, rtt_us=sample.rtt_us,
            converged=True, samples=self._estimate.samples + 1)
        return self._estimate

    def remote_to_local(self, t_us: int) -> int:
        return t_us + self._estimate.offset_us

    def local_to_remote(self, t_us: int) -> int:
        return t_us - self._estimate.offset_us

    def reset(self) -> None:
        self._estimate = TimesyncEstimate(resets=self._estimate.resets + 1)


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
